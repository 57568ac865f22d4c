// SPDX-License-Identifier: MIT
/*
 * can-utils text (candump, candump -l, cansend) -> struct rmd_frame.
 * See rmd/candump.h for the shapes.  Everything here is pure and rt-safe.
 */
#include <errno.h>
#include <stddef.h>
#include <string.h>

#include "rmd/candump.h"

/* Each is followed by the offending text in quotes when there is some. */
static const char *const err_text[RMD_CANDUMP_ERR_COUNT] = {
	[RMD_CANDUMP_OK] = "ok",
	[RMD_CANDUMP_EMPTY] = "empty line",
	[RMD_CANDUMP_BAD_TIMESTAMP] = "bad timestamp, expected (SECONDS.FRACTION):",
	[RMD_CANDUMP_BAD_IFACE] = "interface name longer than 15 characters",
	[RMD_CANDUMP_NO_SEPARATOR] = "missing '#' (or [LEN]) after CAN id",
	[RMD_CANDUMP_BAD_ID] = "bad CAN id",
	[RMD_CANDUMP_ID_RANGE] = "CAN id too large for 11 bits",
	[RMD_CANDUMP_BAD_DLC] = "bad length field, expected [0]..[8]:",
	[RMD_CANDUMP_DLC_RANGE] = "DLC greater than 8",
	[RMD_CANDUMP_BAD_HEX] = "bad hex byte",
	[RMD_CANDUMP_ODD_DIGITS] = "odd number of hex digits, truncated byte",
	[RMD_CANDUMP_TRUNCATED] = "truncated: fewer data bytes than",
	[RMD_CANDUMP_TOO_LONG] = "too many data bytes:",
	[RMD_CANDUMP_UNSUPPORTED] = "remote and CAN FD frames are not supported:",
	[RMD_CANDUMP_TRAILING] = "unexpected text after the frame:",
};

const char *rmd_candump_strerror(enum rmd_candump_err err)
{
	if ((unsigned)err >= RMD_CANDUMP_ERR_COUNT || !err_text[err])
		return "unknown error";
	return err_text[err];
}

/* A parse in progress: the line, where we are, where it ends. */
struct cursor {
	const char *line;
	const char *p;
	const char *end; /* trailing blanks and line break excluded */
	struct rmd_candump_line *out;
};

struct token {
	const char *s;
	size_t len;
};

static bool is_blank(char c)
{
	return c == ' ' || c == '\t';
}

static int hex_val(char c)
{
	if (c >= '0' && c <= '9')
		return c - '0';
	if (c >= 'a' && c <= 'f')
		return c - 'a' + 10;
	if (c >= 'A' && c <= 'F')
		return c - 'A' + 10;
	return -1;
}

static uint16_t clamp16(size_t v)
{
	return v > UINT16_MAX ? UINT16_MAX : (uint16_t)v;
}

/* Record error `e` about `len` chars at `s`; returns `ret` for tail calls. */
static int fail(struct cursor *c, enum rmd_candump_err e, const char *s, size_t len, int ret)
{
	c->out->err = e;
	c->out->err_off = clamp16((size_t)(s - c->line));
	c->out->err_len = clamp16(len);
	return ret;
}

static int fail_tok(struct cursor *c, enum rmd_candump_err e, struct token t, int ret)
{
	return fail(c, e, t.s, t.len, ret);
}

/* Next blank-separated token; false (and an empty token at the end) when none is left. */
static bool next_token(struct cursor *c, struct token *t)
{
	while (c->p < c->end && is_blank(*c->p))
		c->p++;
	t->s = c->p;
	while (c->p < c->end && !is_blank(*c->p))
		c->p++;
	t->len = (size_t)(c->p - t->s);
	return t->len > 0;
}

static bool tok_is(struct token t, const char *word)
{
	return t.len == strlen(word) && memcmp(t.s, word, t.len) == 0;
}

/* "(SECONDS.FRACTION)" at c->p: up to 19 digits, a dot, 1..9 digits. */
static int parse_time(struct cursor *c)
{
	const char *s = c->p, *q = s + 1;
	struct rmd_candump_line *out = c->out;
	size_t n = 0;
	struct token bad = { s, 0 };

	while (bad.s + bad.len < c->end && !is_blank(bad.s[bad.len])) {
		bad.len++;
		if (bad.s[bad.len - 1] == ')')
			break;
	}
	for (; q < c->end && *q >= '0' && *q <= '9'; q++, n++)
		if (n < 19)
			out->time_sec = out->time_sec * 10 + (uint64_t)(*q - '0');
	if (n == 0 || n > 19 || q >= c->end || *q != '.')
		return fail_tok(c, RMD_CANDUMP_BAD_TIMESTAMP, bad, -EINVAL);
	for (q++, n = 0; q < c->end && *q >= '0' && *q <= '9'; q++, n++)
		if (n < 9)
			out->time_frac = out->time_frac * 10 + (uint32_t)(*q - '0');
	if (n == 0 || n > 9 || q >= c->end || *q != ')')
		return fail_tok(c, RMD_CANDUMP_BAD_TIMESTAMP, bad, -EINVAL);
	out->time_digits = (uint8_t)n;
	out->has_time = true;
	c->p = q + 1;
	return 0;
}

/* An 11-bit identifier of 1..3 hex digits (can-utils writes 8 for 29-bit ones). */
static int parse_id(struct cursor *c, struct token t)
{
	uint32_t id = 0;

	if (t.len == 0)
		return fail_tok(c, RMD_CANDUMP_BAD_ID, t, -EINVAL);
	for (size_t i = 0; i < t.len; i++) {
		int v = hex_val(t.s[i]);

		if (v < 0)
			return fail_tok(c, RMD_CANDUMP_BAD_ID, t, -EINVAL);
		if (i < 8)
			id = id << 4 | (uint32_t)v;
	}
	if (t.len > 3 || id > RMD_CANDUMP_MAX_ID)
		return fail_tok(c, RMD_CANDUMP_ID_RANGE, t, -ERANGE);
	c->out->frame.can_id = id;
	return 0;
}

/* Nothing, or (in the log shape) a lone "T" / "R" direction token. */
static int parse_end(struct cursor *c, bool allow_dir)
{
	struct token t;

	if (!next_token(c, &t))
		return 0;
	if (allow_dir && (tok_is(t, "T") || tok_is(t, "R"))) {
		struct token more;

		if (!next_token(c, &more))
			return 0;
		t = more;
	}
	return fail(c, RMD_CANDUMP_TRAILING, t.s, (size_t)(c->end - t.s), -EINVAL);
}

/* "ID#DATA": DATA is 0..8 bytes of two hex digits, optionally '.'-separated. */
static int parse_hash_frame(struct cursor *c, struct token t)
{
	struct rmd_frame *f = &c->out->frame;
	const char *hash = memchr(t.s, '#', t.len);
	const char *q, *tend = t.s + t.len;
	int r;

	r = parse_id(c, (struct token){ t.s, (size_t)(hash - t.s) });
	if (r < 0)
		return r;
	q = hash + 1;
	/* can-utils lib.c: "ID#R" is a remote frame, "ID##F..." CAN FD. */
	if (q < tend && (*q == '#' || *q == 'R' || *q == 'r'))
		return fail_tok(c, RMD_CANDUMP_UNSUPPORTED, t, -EOPNOTSUPP);
	while (q < tend) {
		int hi, lo;

		if (*q == '.') {
			q++;
			continue;
		}
		hi = hex_val(q[0]);
		if (q + 1 >= tend) {
			if (hi < 0)
				return fail(c, RMD_CANDUMP_BAD_HEX, q, 1, -EINVAL);
			return fail(c, RMD_CANDUMP_ODD_DIGITS, q, 1, -EINVAL);
		}
		lo = hex_val(q[1]);
		if (hi < 0 || lo < 0)
			return fail(c, RMD_CANDUMP_BAD_HEX, q, 2, -EINVAL);
		if (f->len == RMD_FRAME_LEN)
			return fail(c, RMD_CANDUMP_TOO_LONG, q, (size_t)(tend - q), -EINVAL);
		f->data[f->len++] = (uint8_t)(hi << 4 | lo);
		q += 2;
	}
	return parse_end(c, true);
}

static bool is_hex_byte(struct token t)
{
	return t.len == 2 && hex_val(t.s[0]) >= 0 && hex_val(t.s[1]) >= 0;
}

/* "[N]" or candump's CAN FD "[NN]". */
static int parse_dlc(struct cursor *c, struct token t, uint8_t *len)
{
	unsigned n = 0;

	if (t.len < 3 || t.len > 4 || t.s[0] != '[' || t.s[t.len - 1] != ']')
		return fail_tok(c, RMD_CANDUMP_BAD_DLC, t, -EINVAL);
	for (size_t i = 1; i + 1 < t.len; i++) {
		if (t.s[i] < '0' || t.s[i] > '9')
			return fail_tok(c, RMD_CANDUMP_BAD_DLC, t, -EINVAL);
		n = n * 10 + (unsigned)(t.s[i] - '0');
	}
	if (n > RMD_FRAME_LEN)
		return fail_tok(c, RMD_CANDUMP_DLC_RANGE, t, -ERANGE);
	*len = (uint8_t)n;
	return 0;
}

/* "ID  [N]  B0 B1 ..." optionally followed by candump -a's "'ascii'" column. */
static int parse_spaced_frame(struct cursor *c, struct token id)
{
	struct rmd_frame *f = &c->out->frame;
	struct token t, dlc;
	uint8_t n;
	int r;

	r = parse_id(c, id);
	if (r < 0)
		return r;
	next_token(c, &dlc);
	r = parse_dlc(c, dlc, &n);
	if (r < 0)
		return r;
	while (f->len < n) {
		if (!next_token(c, &t) || t.s[0] == '\'')
			return fail_tok(c, RMD_CANDUMP_TRUNCATED, dlc, -EINVAL);
		if (f->len == 0 && tok_is(t, "remote"))
			return fail(c, RMD_CANDUMP_UNSUPPORTED, t.s, (size_t)(c->end - t.s),
				    -EOPNOTSUPP);
		if (!is_hex_byte(t))
			return fail_tok(c, RMD_CANDUMP_BAD_HEX, t, -EINVAL);
		f->data[f->len++] = (uint8_t)(hex_val(t.s[0]) << 4 | hex_val(t.s[1]));
	}
	if (!next_token(c, &t))
		return 0;
	/* candump -a: the ASCII column may itself hold blanks; it ends the line. */
	if (t.s[0] == '\'' && c->end - t.s >= 2 && c->end[-1] == '\'')
		return 0;
	if (is_hex_byte(t))
		return fail(c, RMD_CANDUMP_TOO_LONG, t.s, (size_t)(c->end - t.s), -EINVAL);
	return fail(c, RMD_CANDUMP_TRAILING, t.s, (size_t)(c->end - t.s), -EINVAL);
}

int rmd_candump_parse(const char *line, struct rmd_candump_line *out)
{
	struct cursor c = { line, line, line + strlen(line), out };
	struct token t;
	int r;

	memset(out, 0, sizeof(*out));
	while (c.end > c.p && (is_blank(c.end[-1]) || c.end[-1] == '\n' || c.end[-1] == '\r'))
		c.end--;
	while (c.p < c.end && is_blank(*c.p))
		c.p++;
	if (c.p == c.end)
		return fail(&c, RMD_CANDUMP_EMPTY, c.p, 0, -ENODATA);
	if (*c.p == '(') {
		r = parse_time(&c);
		if (r < 0)
			return r;
	}
	if (!memchr(c.p, '#', (size_t)(c.end - c.p)) && !memchr(c.p, '[', (size_t)(c.end - c.p))) {
		next_token(&c, &t);
		return fail_tok(&c, RMD_CANDUMP_NO_SEPARATOR, t, -EINVAL);
	}
	if (!next_token(&c, &t))
		return fail_tok(&c, RMD_CANDUMP_BAD_ID, t, -EINVAL);
	if (memchr(t.s, '#', t.len))
		return parse_hash_frame(&c, t);

	/* t names the interface. */
	if (t.len >= RMD_CANDUMP_IFNAMSIZ)
		return fail_tok(&c, RMD_CANDUMP_BAD_IFACE, t, -EINVAL);
	memcpy(out->iface, t.s, t.len);
	out->iface[t.len] = '\0';
	next_token(&c, &t);
	/* candump -x: "RX - -" / "TX B E" (direction, BRS, ESI) after the interface. */
	if (tok_is(t, "RX") || tok_is(t, "TX")) {
		next_token(&c, &t);
		next_token(&c, &t);
		next_token(&c, &t);
	}
	if (memchr(t.s, '#', t.len))
		return parse_hash_frame(&c, t);
	return parse_spaced_frame(&c, t);
}
