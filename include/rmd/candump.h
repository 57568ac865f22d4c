/* SPDX-License-Identifier: MIT */
/*
 * One line of can-utils text -> struct rmd_frame, for rmdctl and tests.
 *
 * Accepted shapes (hex digits in either case):
 *   candump:             "  can0  241   [8]  9A 32 00 01 E5 01 04 00"
 *   candump -ta/-td/-tz: " (000.000123)  can0  241   [8]  9A 32 ..."
 *   candump -x:          "  can0  RX - -  241   [8]  9A 32 ..."
 *   candump -a:          the data may be followed by "  '..2.....'"
 *   candump -l log:      "(1700000000.000000) can0 241#9A320001E5010400"
 *   cansend:             "241#9A320001E5010400" (bytes may be '.'-separated)
 * The log shape may end in a "T" or "R" direction token.
 *
 * Only classical data frames with 11-bit identifiers are frames of the RMD
 * protocols: extended identifiers, remote, CAN FD and error frames are
 * refused with a reason, as is every malformed line.
 *
 * Layer 1 of docs/design.md: pure, no allocation, no locale, rt-safe.
 */
#ifndef RMD_CANDUMP_H
#define RMD_CANDUMP_H

#include <stdbool.h>
#include <stdint.h>

#include "rmd/frame.h"

/* Linux IFNAMSIZ: 15 characters and the NUL. */
#define RMD_CANDUMP_IFNAMSIZ 16
/* Largest 11-bit identifier. */
#define RMD_CANDUMP_MAX_ID 0x7FFu

/* Why a line was refused.  rmd_candump_strerror() names each one. */
enum rmd_candump_err {
	RMD_CANDUMP_OK = 0,
	RMD_CANDUMP_EMPTY,	   /* nothing but blanks */
	RMD_CANDUMP_BAD_TIMESTAMP, /* "(" not followed by "SECONDS.FRACTION)" */
	RMD_CANDUMP_BAD_IFACE,	   /* interface name longer than 15 characters */
	RMD_CANDUMP_NO_SEPARATOR,  /* neither "ID#DATA" nor "ID [LEN] DATA" */
	RMD_CANDUMP_BAD_ID,	   /* CAN id missing or not hexadecimal */
	RMD_CANDUMP_ID_RANGE,	   /* CAN id wider than 11 bits */
	RMD_CANDUMP_BAD_DLC,	   /* "[LEN]" missing or malformed */
	RMD_CANDUMP_DLC_RANGE,	   /* LEN greater than 8 */
	RMD_CANDUMP_BAD_HEX,	   /* a data byte that is not two hex digits */
	RMD_CANDUMP_ODD_DIGITS,	   /* "ID#DATA" whose DATA ends in half a byte */
	RMD_CANDUMP_TRUNCATED,	   /* fewer data bytes than "[LEN]" announces */
	RMD_CANDUMP_TOO_LONG,	   /* more than 8 (or than LEN) data bytes */
	RMD_CANDUMP_UNSUPPORTED,   /* remote, CAN FD or error frame */
	RMD_CANDUMP_TRAILING,	   /* text after the frame */
	RMD_CANDUMP_ERR_COUNT
};

struct rmd_candump_line {
	struct rmd_frame frame;
	char iface[RMD_CANDUMP_IFNAMSIZ]; /* "" when the line names none */
	bool has_time;			  /* the line began with "(S.F)" */
	uint64_t time_sec;		  /* S */
	uint32_t time_frac;		  /* F as an integer ... */
	uint8_t time_digits;		  /* ... of this many digits (0..9) */
	/* Set on every return; on error the offending text is err_len chars at err_off. */
	enum rmd_candump_err err;
	uint16_t err_off;
	uint16_t err_len;
};

/*
 * Parse one NUL-terminated line (a trailing "\n" or "\r\n" is allowed) into
 * *out.  Returns 0; -ENODATA for a blank line; -ERANGE for an identifier or
 * length out of range; -EOPNOTSUPP for remote, CAN FD and error frames;
 * -EINVAL for anything else malformed.  out->err says which.
 * rt-safe.
 */
int rmd_candump_parse(const char *line, struct rmd_candump_line *out);

/*
 * Short English text for an error, never NULL, written to be followed by the
 * offending text in quotes: `bad hex byte "ZZ"`.  rt-safe.
 */
const char *rmd_candump_strerror(enum rmd_candump_err err);

#endif /* RMD_CANDUMP_H */
