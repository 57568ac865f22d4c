/* SPDX-License-Identifier: MIT */
/*
 * Hex text for the suites: frames as "241#9A320001E5010400" (can-utils'
 * cansend notation, ID in hex) and plain byte strings as "3E0108...".
 * The parsers fail the running cmocka test on bad text: a typo in a vector
 * is a broken test, never a silently shorter frame.
 */
#ifndef RMD_TESTS_HEX_H
#define RMD_TESTS_HEX_H

#include <stddef.h>
#include <stdint.h>

#include "rmd/frame.h"

/* "ID#DATA" and the NUL: the longest frame_hex() writes. */
#define HEX_FRAME_LEN (8 + 1 + 2 * RMD_FRAME_LEN + 1)

/* "241#9A320001E5010400" -> frame (at most RMD_FRAME_LEN data bytes). */
struct rmd_frame frame_from(const char *s);

/* frame -> "241#9A320001E5010400" in buf (HEX_FRAME_LEN bytes); returns buf. */
const char *frame_hex(const struct rmd_frame *f, char *buf);

/* "3E0108..." -> at most cap bytes in out; returns the count. */
size_t bytes_from(const char *s, uint8_t *out, size_t cap);

/* n bytes -> "3E0108..." in buf (2 * n + 1 bytes); returns buf. */
const char *hex_of(const uint8_t *b, size_t n, char *buf);

#endif /* RMD_TESTS_HEX_H */
