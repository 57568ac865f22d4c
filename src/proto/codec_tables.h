/* SPDX-License-Identifier: MIT */
/* Internal: the command tables the codec interpreter (src/codec.c) reads. */
#ifndef RMD_CODEC_TABLES_H
#define RMD_CODEC_TABLES_H

#include <stddef.h>

#include "rmd/codec.h"

extern const struct rmd_cmd_spec rmd_v3_cmds[];
extern const size_t rmd_v3_ncmds;
extern const struct rmd_cmd_spec rmd_v2_cmds[];
extern const size_t rmd_v2_ncmds;
extern const struct rmd_cmd_spec rmd_v4_cmds[];
extern const size_t rmd_v4_ncmds;

/*
 * Around a table: a row's last members, its words for tools (RMD_SAY*) and
 * its ranges (RMD_RANGES), may be left out of its initializer, and are
 * then none (zero).
 */
#define RMD_ROWS_BEGIN                 \
	_Pragma("GCC diagnostic push") \
		_Pragma("GCC diagnostic ignored \"-Wmissing-field-initializers\"")
#define RMD_ROWS_END _Pragma("GCC diagnostic pop")

/* Table-writing shorthands: signed / unsigned little-endian fields. */
#define RMD_S(fld, off, size, scale)                                      \
	{                                                                 \
		RMD_FLD_##fld, (off), (size), true, (scale), false, false \
	}
#define RMD_U(fld, off, size, scale)                                       \
	{                                                                  \
		RMD_FLD_##fld, (off), (size), false, (scale), false, false \
	}
/* A signed field of `size` bytes with a sign-flag byte after it (rmd_field_spec.sign_byte). */
#define RMD_SF(fld, off, size, scale)                                    \
	{                                                                \
		RMD_FLD_##fld, (off), (size), true, (scale), true, false \
	}
/* A little-endian IEEE 754 binary32 at data[off..off + 3] (rmd_field_spec.is_float). */
#define RMD_F(fld, off)                                          \
	{                                                        \
		RMD_FLD_##fld, (off), 4, false, 1.0, false, true \
	}
/* A layout without fields (a request or reply of the command byte alone, or none). */
#define RMD_LAYOUT_NONE \
	{               \
		0       \
	}
/*
 * A row's words for tools and the fields their arguments fill, in order
 * (struct rmd_spelling): RMD_SAY2("position", ANGLE, MAX_SPEED).
 */
#define RMD_SAY0(w)                       \
	{                                 \
		.words = (w), .n_args = 0 \
	}
#define RMD_SAY1(w, a)                                             \
	{                                                          \
		.words = (w), .n_args = 1, .args = { RMD_FLD_##a } \
	}
#define RMD_SAY2(w, a, b)                                                       \
	{                                                                       \
		.words = (w), .n_args = 2, .args = { RMD_FLD_##a, RMD_FLD_##b } \
	}
#define RMD_SAY3(w, a, b, c)                                                                 \
	{                                                                                    \
		.words = (w), .n_args = 3, .args = { RMD_FLD_##a, RMD_FLD_##b, RMD_FLD_##c } \
	}
#define RMD_SAY4(w, a, b, c, d)                      \
	{                                            \
		.words = (w), .n_args = 4, .args = { \
			RMD_FLD_##a,                 \
			RMD_FLD_##b,                 \
			RMD_FLD_##c,                 \
			RMD_FLD_##d                  \
		}                                    \
	}
/* A row tools do not name (rmdctl encode reaches it as `raw`). */
#define RMD_SAY_NONE \
	{            \
		0    \
	}
/* The manual's range of a request field, native units (struct rmd_field_range). */
#define RMD_RANGE(fld, lo, hi, cite)              \
	{                                         \
		RMD_FLD_##fld, (lo), (hi), (cite) \
	}
/* A row's ranges: the last two members of struct rmd_cmd_spec. */
#define RMD_RANGES(...)                                  \
	(const struct rmd_field_range[]){ __VA_ARGS__ }, \
		sizeof((struct rmd_field_range[]){ __VA_ARGS__ }) / sizeof(struct rmd_field_range)
#define RMD_LAYOUT(...)                                                 \
	{                                                               \
		.n = sizeof((struct rmd_field_spec[]){ __VA_ARGS__ }) / \
		     sizeof(struct rmd_field_spec),                     \
		.f = { __VA_ARGS__ }                                    \
	}

#endif /* RMD_CODEC_TABLES_H */
