// SPDX-License-Identifier: MIT
/*
 * What rmdctl's command lines share, below main.c and the commands: decode's
 * and encode's options, numbers, usage hints, and the protocol keys as the
 * help texts say them (from the dialect list, rmd/dialect.h).  Non-rt.
 */
#include <errno.h>
#include <getopt.h>
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "rmdctl.h"

void rmdctl_usage_hint_args(const char *name, const char *args)
{
	char line[160], help[64];

	if (!name) {
		tool_usage_hint("rmdctl COMMAND [ARGS...]  (rmdctl help lists the commands)",
				"rmdctl --help");
		return;
	}
	snprintf(line, sizeof(line), "rmdctl %s [OPTIONS]%s%s", name, args ? " " : "",
		 args ? args : "");
	snprintf(help, sizeof(help), "rmdctl %s --help", name);
	tool_usage_hint(line, help);
}

void rmdctl_usage_hint(const struct rmdctl_cmd *c)
{
	if (!c)
		rmdctl_usage_hint_args(NULL, NULL);
	else
		rmdctl_usage_hint_args(c->name, c->args);
}

int rmdctl_codec_getopt(int argc, char **argv, const struct rmdctl_codec_cmd *cmd,
			enum rmd_proto *proto, struct rmd_mit_ranges *ranges,
			int (*own)(int c, void *ctx), void *ctx)
{
	const struct tool_opt *o = cmd->opts;
	size_t n = cmd->n_opts;
	struct option longopts[16];
	char shorts[40], msg[160];
	int c;

	if (n >= sizeof(longopts) / sizeof(longopts[0]))
		n = sizeof(longopts) / sizeof(longopts[0]) - 1;
	/* '+': stop at the first operand */
	shorts[0] = '+';
	tool_opts_getopt(o, n, longopts, shorts + 1, sizeof(shorts) - 1);
	optind = 0; /* glibc: full re-initialisation */
	opterr = 0;
	while ((c = getopt_long(argc, argv, cmd->stop_at_operand ? shorts : shorts + 1, longopts,
				NULL)) != -1) {
		switch (c) {
		case 'p':
			if (rmd_proto_parse(optarg, proto) < 0) {
				char keys[64];

				tool_log(TOOL_LOG_ERR, "unknown protocol \"%s\" (%s)", optarg,
					 rmd_proto_keys_text(keys, sizeof(keys), ", ", " or "));
				goto usage;
			}
			break;
		case 'm':
			if (rmd_mit_ranges_parse(optarg, ranges) < 0) {
				tool_log(TOOL_LOG_ERR,
					 "bad --mit-ranges \"%s\" (five positive numbers "
					 "P,V,T,KP,KD, each at most %g)",
					 optarg, RMD_MIT_RANGE_LIMIT);
				goto usage;
			}
			break;
		case 'h':
			cmd->usage(stdout);
			return RMDCTL_EXIT_OK;
		case 'y':
			break; /* nothing to confirm */
		case ':':
		case '?':
			tool_log(TOOL_LOG_ERR, "%s",
				 tool_getopt_error(msg, sizeof(msg), c, argv, o, n));
			goto usage;
		default:
			if (own(c, ctx) < 0)
				goto usage;
			break;
		}
	}
	return -1;
usage:
	rmdctl_usage_hint_args(cmd->name, cmd->args);
	return RMDCTL_EXIT_USAGE;
}

int rmdctl_parse_double(const char *s, double *v)
{
	char *end;

	errno = 0;
	*v = strtod(s, &end);
	if (end == s || *end != '\0' || errno == ERANGE || !isfinite(*v))
		return -EINVAL;
	return 0;
}

const char *rmdctl_proto_help(char *buf, size_t size, bool firmware_only)
{
	const struct rmd_dialect *list, *def = rmd_dialect(RMDCTL_PROTO_DEFAULT);
	size_t n, k = 0, last = 0, said = 0;
	bool noted = false;

	if (!size)
		return buf;
	buf[0] = '\0';
	list = rmd_dialect_list(&n);
	for (size_t i = 0; i < n; i++)
		if (!firmware_only || rmd_dialect_is_firmware(&list[i]))
			last = i;
	for (size_t i = 0; i < n && k < size; i++) {
		const struct rmd_dialect *d = &list[i];
		/* "v2 or v4", but "mit (= v3 tables plus `mit`), or v4" */
		const char *sep = !said ? "" : i != last ? ", " : noted ? ", or " : " or ";
		int w;

		if (firmware_only && !rmd_dialect_is_firmware(d))
			continue;
		w = snprintf(buf + k, size - k, "%s%s%s", sep, d->key,
			     d == def ? " (default)" : "");
		noted = d == def;
		if (w > 0)
			k += (size_t)w;
		if (!rmd_dialect_is_firmware(d) && k < size) {
			/* V3 firmware driven in MIT: its tables, and the `mit` command */
			w = snprintf(buf + k, size - k, " (= %s tables plus `mit`)",
				     rmd_dialect_firmware(d)->key);
			noted = true;
			if (w > 0)
				k += (size_t)w;
		}
		said++;
	}
	return buf;
}
