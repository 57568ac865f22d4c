/* SPDX-License-Identifier: MIT */
/*
 * A dialect of its own, for tests/unit/test_new_dialect.c only: "V5", made
 * up, with a command table of its own (codec_v5.c) and identifiers no real
 * dialect uses, added as docs/design.md "How to add a dialect" says: its
 * key in enum rmd_proto, its table, its row of the list.  The test build
 * gives this header to every file it compiles (-include): the proto layer
 * and rmdctl's encode and decode, whose sources it leaves as they are.
 * No production build includes it.
 */
#ifndef RMD_TEST_DIALECT_V5_H
#define RMD_TEST_DIALECT_V5_H

/* The key (codec.h), before the enum is read. */
#define RMD_PROTO_MORE RMD_PROTO_V5

#include <stddef.h>

#include "rmd/dialect.h"

extern const struct rmd_cmd_spec rmd_v5_cmds[];
extern const size_t rmd_v5_ncmds;
#define RMD_V5_N_ERROR_BITS 2
extern const struct rmd_flag_name rmd_v5_error_bits[RMD_V5_N_ERROR_BITS];

/* Its row of the list (dialect.c); requests on 0x600 + ID, replies on 0x680 + ID. */
#define RMD_DIALECTS_MORE                                          \
	[RMD_PROTO_V5] = {                                         \
		.proto = RMD_PROTO_V5,                             \
		.key = "v5",                                       \
		.name = "V5",                                      \
		.manual = "a test's own (tests/unit/new_dialect)", \
		.table = RMD_PROTO_V5,                             \
		.rows = rmd_v5_cmds,                               \
		.n_rows = &rmd_v5_ncmds,                           \
		.req_base = 0x600,                                 \
		.reply_base = 0x680,                               \
		.ctl_req_base = 0x600,                             \
		.ctl_reply_base = 0x680,                           \
		.error_bits = rmd_v5_error_bits,                   \
		.n_error_bits = RMD_V5_N_ERROR_BITS,               \
		.probe = { 0x9A },                                 \
		.n_probes = 1,                                     \
	},

#endif /* RMD_TEST_DIALECT_V5_H */
