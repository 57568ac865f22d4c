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
#define RMD_LAYOUT(...)                                                 \
	{                                                               \
		.n = sizeof((struct rmd_field_spec[]){ __VA_ARGS__ }) / \
		     sizeof(struct rmd_field_spec),                     \
		.f = { __VA_ARGS__ }                                    \
	}

#endif /* RMD_CODEC_TABLES_H */
