// SPDX-License-Identifier: MIT
/*
 * candump text parser tests: every accepted shape as a named vector
 * {name, line, frame}, and malformed lines with the reason and the offending
 * text each must report.
 */
#include <errno.h>
#include <setjmp.h>
#include <stdarg.h>
#include <stddef.h>
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include <cmocka.h>

#include "rmd/candump.h"

#include "harness/hex.h"
#include "harness/suite.h"

struct good_vector {
	const char *name;
	const char *line;
	uint32_t can_id;
	const char *hex; /* data bytes, "" for none */
	const char *iface;
	const char *time; /* "S.F" or NULL */
};

static const struct good_vector good[] = {
	{ "candump default", "  can0  241   [8]  9A 32 00 01 E5 01 04 00", 0x241,
	  "9A320001E5010400", "can0", NULL },
	{ "candump lowercase", "  can0  241   [8]  9a 32 00 01 e5 01 04 00", 0x241,
	  "9A320001E5010400", "can0", NULL },
	{ "candump -ta", " (1700000000.123456)  can1  141   [8]  A1 00 00 00 64 00 00 00", 0x141,
	  "A100000064000000", "can1", "1700000000.123456" },
	{ "candump -td", " (000.000123)  vcan0  141   [8]  A1 00 00 00 64 00 00 00", 0x141,
	  "A100000064000000", "vcan0", "0.000123" },
	{ "candump -x", "  can0  RX - -  241   [8]  9A 32 00 01 E5 01 04 00", 0x241,
	  "9A320001E5010400", "can0", NULL },
	{ "candump -a", "  can0  241   [8]  9A 32 00 01 E5 01 04 00   '.2......'", 0x241,
	  "9A320001E5010400", "can0", NULL },
	{ "candump -a blanks in ascii", "  can0  241   [2]  20 41   ' A'", 0x241, "2041", "can0",
	  NULL },
	{ "candump short dlc", "  can0  7FF   [2]  01 02", 0x7FF, "0102", "can0", NULL },
	{ "candump dlc 0", "  can0  001   [0]", 0x001, "", "can0", NULL },
	{ "candump fd-style [08]", "  can0  241  [08]  9A 32 00 01 E5 01 04 00", 0x241,
	  "9A320001E5010400", "can0", NULL },
	{ "candump tabs and CRLF", "\tcan0\t241\t[8]\t9A 32 00 01 E5 01 04 00\r\n", 0x241,
	  "9A320001E5010400", "can0", NULL },
	{ "log", "(1700000000.000000) can0 241#9A320001E5010400", 0x241, "9A320001E5010400", "can0",
	  "1700000000.000000" },
	{ "log with direction", "(1700000000.000000) can0 241#9A320001E5010400 R", 0x241,
	  "9A320001E5010400", "can0", "1700000000.000000" },
	{ "log newline", "(1.5) can0 141#A2000000F0D8FFFF\n", 0x141, "A2000000F0D8FFFF", "can0",
	  "1.5" },
	{ "bare", "241#9A320001E5010400", 0x241, "9A320001E5010400", "", NULL },
	{ "bare lowercase", "241#9a320001e5010400", 0x241, "9A320001E5010400", "", NULL },
	{ "bare dotted", "241#9A.32.00.01.E5.01.04.00", 0x241, "9A320001E5010400", "", NULL },
	{ "bare empty data", "123#", 0x123, "", "", NULL },
	{ "bare short id", "1#01", 0x001, "01", "", NULL },
	{ "bare leading blanks", "   401#E66682E052333B55  ", 0x401, "E66682E052333B55", "", NULL },
	{ "iface and bare", "can0 241#9A320001E5010400", 0x241, "9A320001E5010400", "can0", NULL },
};

static void test_good_lines(void **state)
{
	(void)state;
	for (size_t i = 0; i < sizeof(good) / sizeof(good[0]); i++) {
		const struct good_vector *v = &good[i];
		struct rmd_candump_line l;
		char hex[2 * RMD_FRAME_LEN + 1], time[48] = "";
		int r = rmd_candump_parse(v->line, &l);

		if (r != 0)
			fail_msg("%s: returned %d (%s)", v->name, r, rmd_candump_strerror(l.err));
		hex_of(l.frame.data, l.frame.len, hex);
		if (l.has_time)
			snprintf(time, sizeof(time), "%llu.%0*u", (unsigned long long)l.time_sec,
				 (int)l.time_digits, (unsigned)l.time_frac);
		if (l.frame.can_id != v->can_id || strcmp(hex, v->hex) ||
		    strcmp(l.iface, v->iface) || l.has_time != (v->time != NULL) ||
		    (v->time && strcmp(time, v->time)) || l.err != RMD_CANDUMP_OK)
			fail_msg("%s: got id %03X data \"%s\" iface \"%s\" time \"%s\"", v->name,
				 (unsigned)l.frame.can_id, hex, l.iface, time);
	}
}

struct bad_vector {
	const char *name;
	const char *line;
	int ret;
	enum rmd_candump_err err;
	const char *text; /* the offending text reported */
};

static const struct bad_vector bad[] = {
	{ "empty", "", -ENODATA, RMD_CANDUMP_EMPTY, "" },
	{ "blanks", "  \t \r\n", -ENODATA, RMD_CANDUMP_EMPTY, "" },
	{ "bad hex candump", "  can0  241   [8]  9A 32 ZZ 01 E5 01 04 00", -EINVAL,
	  RMD_CANDUMP_BAD_HEX, "ZZ" },
	{ "bad hex bare", "241#9A3200ZZE5010400", -EINVAL, RMD_CANDUMP_BAD_HEX, "ZZ" },
	{ "three-digit byte", "  can0  241   [8]  9A 320 00 01 E5 01 04 00", -EINVAL,
	  RMD_CANDUMP_BAD_HEX, "320" },
	{ "truncated candump", "  can0  241   [8]  9A 32 00", -EINVAL, RMD_CANDUMP_TRUNCATED,
	  "[8]" },
	{ "truncated before ascii", "  can0  241   [8]  9A 32   '.2'", -EINVAL,
	  RMD_CANDUMP_TRUNCATED, "[8]" },
	{ "odd digits bare", "241#9A320001E501040", -EINVAL, RMD_CANDUMP_ODD_DIGITS, "0" },
	{ "missing hash", "241 9A320001E5010400", -EINVAL, RMD_CANDUMP_NO_SEPARATOR, "241" },
	{ "missing hash and dlc", "  can0  241  9A 32 00 01", -EINVAL, RMD_CANDUMP_NO_SEPARATOR,
	  "can0" },
	{ "dlc 9", "  can0  241   [9]  9A 32 00 01 E5 01 04 00 00", -ERANGE, RMD_CANDUMP_DLC_RANGE,
	  "[9]" },
	{ "dlc 64", "  can0  241  [64]  00", -ERANGE, RMD_CANDUMP_DLC_RANGE, "[64]" },
	{ "bad dlc", "  can0  241   [x]  00", -EINVAL, RMD_CANDUMP_BAD_DLC, "[x]" },
	{ "no dlc", "  can0  241   9A [", -EINVAL, RMD_CANDUMP_BAD_DLC, "9A" },
	{ "more bytes than dlc", "  can0  241   [2]  9A 32 00", -EINVAL, RMD_CANDUMP_TOO_LONG,
	  "00" },
	{ "nine bytes bare", "241#9A320001E501040000", -EINVAL, RMD_CANDUMP_TOO_LONG, "00" },
	{ "id too large bare", "800#9A320001E5010400", -ERANGE, RMD_CANDUMP_ID_RANGE, "800" },
	{ "id too large candump", "  can0  FFF   [1]  00", -ERANGE, RMD_CANDUMP_ID_RANGE, "FFF" },
	{ "extended id", "  can0  12345678   [1]  00", -ERANGE, RMD_CANDUMP_ID_RANGE, "12345678" },
	{ "extended id bare", "00000241#00", -ERANGE, RMD_CANDUMP_ID_RANGE, "00000241" },
	{ "bad id", "24G#00", -EINVAL, RMD_CANDUMP_BAD_ID, "24G" },
	{ "empty id", "#00", -EINVAL, RMD_CANDUMP_BAD_ID, "" },
	{ "remote bare", "241#R", -EOPNOTSUPP, RMD_CANDUMP_UNSUPPORTED, "241#R" },
	{ "remote candump", "  can0  241   [8]  remote request", -EOPNOTSUPP,
	  RMD_CANDUMP_UNSUPPORTED, "remote request" },
	{ "can fd bare", "241##19A32", -EOPNOTSUPP, RMD_CANDUMP_UNSUPPORTED, "241##19A32" },
	{ "bad timestamp", "(17x) can0 241#00", -EINVAL, RMD_CANDUMP_BAD_TIMESTAMP, "(17x)" },
	{ "unclosed timestamp", "(1700000000.000000 can0 241#00", -EINVAL,
	  RMD_CANDUMP_BAD_TIMESTAMP, "(1700000000.000000" },
	{ "long iface", "  averyveryverylongname  241   [1]  00", -EINVAL, RMD_CANDUMP_BAD_IFACE,
	  "averyveryverylongname" },
	{ "trailing junk", "241#9A320001E5010400 junk", -EINVAL, RMD_CANDUMP_TRAILING, "junk" },
	{ "trailing junk candump", "  can0  241   [1]  00 xyz", -EINVAL, RMD_CANDUMP_TRAILING,
	  "xyz" },
	{ "timestamp only", "(1.000000)", -EINVAL, RMD_CANDUMP_NO_SEPARATOR, "" },
};

static void test_bad_lines(void **state)
{
	(void)state;
	for (size_t i = 0; i < sizeof(bad) / sizeof(bad[0]); i++) {
		const struct bad_vector *v = &bad[i];
		struct rmd_candump_line l;
		int r = rmd_candump_parse(v->line, &l);
		size_t n = strlen(v->text);

		if (r != v->ret || l.err != v->err)
			fail_msg("%s: returned %d err %d (%s), want %d err %d", v->name, r, l.err,
				 rmd_candump_strerror(l.err), v->ret, v->err);
		if (l.err_len != n || (size_t)l.err_off + l.err_len > strlen(v->line) ||
		    memcmp(v->line + l.err_off, v->text, n))
			fail_msg("%s: reported \"%.*s\", want \"%s\"", v->name, (int)l.err_len,
				 v->line + l.err_off, v->text);
	}
}

static void test_strerror(void **state)
{
	(void)state;
	for (int e = 0; e <= RMD_CANDUMP_ERR_COUNT; e++)
		assert_non_null(rmd_candump_strerror((enum rmd_candump_err)e));
	assert_string_equal(rmd_candump_strerror(RMD_CANDUMP_BAD_HEX), "bad hex byte");
}

/* Every prefix of a good line is either a frame or an error, never a crash or overread. */
static void test_every_prefix(void **state)
{
	(void)state;
	for (size_t i = 0; i < sizeof(good) / sizeof(good[0]); i++) {
		size_t len = strlen(good[i].line);

		for (size_t n = 0; n <= len; n++) {
			char *copy = malloc(n + 1); /* exact size: ASan catches overreads */
			struct rmd_candump_line l;
			int r;

			assert_non_null(copy);
			memcpy(copy, good[i].line, n);
			copy[n] = '\0';
			r = rmd_candump_parse(copy, &l);
			if (r == 0)
				assert_true(l.frame.len <= RMD_FRAME_LEN &&
					    l.err == RMD_CANDUMP_OK);
			else
				assert_true(l.err != RMD_CANDUMP_OK &&
					    (size_t)l.err_off + l.err_len <= n);
			free(copy);
		}
	}
}

SUITE_MAIN("candump", NULL, NULL,
	   {
		   cmocka_unit_test(test_good_lines),
		   cmocka_unit_test(test_bad_lines),
		   cmocka_unit_test(test_strerror),
		   cmocka_unit_test(test_every_prefix),
	   })
