// SPDX-License-Identifier: MIT
/* Hex text for the suites (hex.h). */
#include <setjmp.h>
#include <stdarg.h>
#include <stddef.h>
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>

#include <cmocka.h>

#include "harness/hex.h"

/* Two hex digits at s -> *byte.  False when they are not. */
static int hex_byte(const char *s, uint8_t *byte)
{
	char pair[3] = { s[0], s[1], 0 };
	char *end;

	*byte = (uint8_t)strtoul(pair, &end, 16);
	return s[0] && s[0] != '-' && s[0] != '+' && s[0] != ' ' && *end == '\0';
}

struct rmd_frame frame_from(const char *s)
{
	struct rmd_frame f = { 0 };
	const char *p;
	char *end;

	f.can_id = (uint32_t)strtoul(s, &end, 16);
	if (*end != '#')
		fail_msg("bad frame text \"%s\"", s);
	for (p = end + 1; p[0] && p[1] && f.len < RMD_FRAME_LEN; p += 2)
		if (!hex_byte(p, &f.data[f.len++]))
			fail_msg("bad frame text \"%s\"", s);
	if (*p)
		fail_msg("bad frame text \"%s\"", s);
	return f;
}

const char *frame_hex(const struct rmd_frame *f, char *buf)
{
	int n = sprintf(buf, "%03X#", (unsigned)f->can_id);

	hex_of(f->data, f->len < RMD_FRAME_LEN ? f->len : RMD_FRAME_LEN, buf + n);
	return buf;
}

size_t bytes_from(const char *s, uint8_t *out, size_t cap)
{
	size_t n = 0;

	for (; s[0] && s[1]; s += 2) {
		if (n >= cap || !hex_byte(s, &out[n++]))
			fail_msg("bad hex text (or more than %zu bytes) at \"%s\"", cap, s);
	}
	if (*s)
		fail_msg("odd hex digit at \"%s\"", s);
	return n;
}

const char *hex_of(const uint8_t *b, size_t n, char *buf)
{
	for (size_t i = 0; i < n; i++)
		sprintf(buf + 2 * i, "%02X", b[i]);
	buf[2 * n] = '\0';
	return buf;
}
