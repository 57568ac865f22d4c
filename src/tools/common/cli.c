// SPDX-License-Identifier: MIT
/*
 * The programs' command lines from their option tables (cli.h): getopt
 * tables, --help columns, "did you mean", usage hints, --version and the
 * bash completion script.  Non-rt.
 */
#include <stdio.h>
#include <string.h>

#include "rmd/codec.h"
#include "rmd/err.h"
#include "rmd_version.h"
#include "cli.h"

/* --help: the option column is this wide, then the text. */
#define HELP_COL 27

void tool_opts_getopt(const struct tool_opt *o, size_t n, struct option *lo, char *shorts,
		      size_t size)
{
	size_t k = 0;

	if (size)
		shorts[k++] = ':';
	for (size_t i = 0; i < n; i++) {
		lo[i] = (struct option){
			.name = o[i].name,
			.has_arg = o[i].has_arg,
			.val = o[i].shortc ? o[i].shortc : TOOL_OPT_BASE + (int)i,
		};
		if (!o[i].shortc || k + 3 >= size)
			continue;
		shorts[k++] = o[i].shortc;
		if (o[i].has_arg != no_argument)
			shorts[k++] = ':';
		if (o[i].has_arg == optional_argument)
			shorts[k++] = ':';
	}
	lo[n] = (struct option){ 0 };
	if (size)
		shorts[k < size ? k : size - 1] = '\0';
}

void tool_opts_help(FILE *f, const struct tool_opt *o, size_t n)
{
	for (size_t i = 0; i < n; i++) {
		const char *h = o[i].help, *arg = o[i].arg ? o[i].arg : "";
		bool opt = o[i].has_arg == optional_argument;
		char left[80];
		int w;

		if (!h)
			continue;
		if (o[i].shortc)
			w = snprintf(left, sizeof(left), "  -%c, --%s", o[i].shortc, o[i].name);
		else
			w = snprintf(left, sizeof(left), "      --%s", o[i].name);
		if (*arg)
			w += snprintf(left + w, sizeof(left) - (size_t)w, opt ? " [%s]" : " %s",
				      arg);
		fputs(left, f);
		while (*h) {
			size_t len = strcspn(h, "\n");

			/* a long left column puts the text on the next line */
			if (w >= HELP_COL - 1) {
				fputc('\n', f);
				w = 0;
			}
			fprintf(f, "%*s%.*s\n", HELP_COL - w, "", (int)len, h);
			w = 0;
			h += len + (h[len] == '\n');
		}
	}
}

void tool_near_init(struct tool_near *n, const char *word)
{
	*n = (struct tool_near){ .word = word, .best = NULL, .dist = 3 };
}

void tool_near_try(struct tool_near *n, const char *cand)
{
	unsigned d = rmd_edit_distance(n->word, cand);

	/* a short word is "close" to anything: at most a third of it may change */
	if (d < n->dist && 3 * d <= strlen(cand)) {
		n->dist = d;
		n->best = cand;
	}
}

const char *tool_nearest_opt(const char *arg, const struct tool_opt *o, size_t n)
{
	struct tool_near near;
	char word[64];
	size_t len;

	while (*arg == '-')
		arg++;
	len = strcspn(arg, "=");
	if (len >= sizeof(word))
		return NULL;
	memcpy(word, arg, len);
	word[len] = '\0';
	tool_near_init(&near, word);
	for (size_t i = 0; i < n; i++)
		tool_near_try(&near, o[i].name);
	return near.best;
}

const char *tool_getopt_error(char *buf, size_t size, int c, char **argv, const struct tool_opt *o,
			      size_t n)
{
	const char *arg = argv[optind - 1], *near;

	if (c == ':') {
		snprintf(buf, size, "%s needs a value", arg);
		return buf;
	}
	/* an unknown letter of "-xq" is optopt; an unknown long option is the whole word */
	if (optopt && (arg[0] != '-' || arg[1] != '-')) {
		snprintf(buf, size, "unknown option \"-%c\"", optopt);
		return buf;
	}
	near = tool_nearest_opt(arg, o, n);
	if (near)
		snprintf(buf, size, "unknown option \"%s\" (did you mean --%s?)", arg, near);
	else
		snprintf(buf, size, "unknown option \"%s\"", arg);
	return buf;
}

void tool_usage_hint(const char *line, const char *help)
{
	fprintf(stderr, "usage: %s\nsee `%s`\n", line, help);
}

void tool_print_version(const char *prog)
{
	printf("%s %s\n", prog, RMD_VERSION);
}

/* ---- bash completion ---------------------------------------------------------------------- */

/*
 * Helpers of every script: CAN interfaces are the network devices of type
 * 280 (ARPHRD_CAN); RMD_COMPLETION_NET replaces /sys/class/net (tests).
 */
static const char compl_helpers[] =
	"_rmd_can()\n"
	"{\n"
	"\tlocal n t\n"
	"\tfor n in \"${RMD_COMPLETION_NET:-/sys/class/net}\"/*; do\n"
	"\t\t[[ -r $n/type ]] && read -r t <\"$n/type\" && [[ $t == 280 ]] && echo \"${n##*/}\"\n"
	"\tdone\n"
	"}\n"
	"\n"
	"_rmd_serial()\n"
	"{\n"
	"\tlocal n\n"
	"\tfor n in /dev/ttyUSB* /dev/ttyACM* /dev/serial/by-id/*; do\n"
	"\t\t[[ -e $n ]] && echo \"$n\"\n"
	"\tdone\n"
	"}\n";

/* "case $prev in" arms for the options of table o that take a value. */
static void compl_values(FILE *f, const char *in, const struct tool_opt *o, size_t n,
			 unsigned flags)
{
	for (size_t i = 0; i < n; i++) {
		if (o[i].has_arg != required_argument || (o[i].flag && !(o[i].flag & flags)))
			continue;
		fprintf(f, "%s--%s", in, o[i].name);
		if (o[i].shortc)
			fprintf(f, "|-%c", o[i].shortc);
		fprintf(f, ")\n");
		switch (o[i].value) {
		case TOOL_VAL_FILE:
			fprintf(f, "%s\tcompopt -o filenames 2>/dev/null\n", in);
			fprintf(f, "%s\tCOMPREPLY=($(compgen -f -- \"$cur\"))\n", in);
			break;
		case TOOL_VAL_BUS:
			fprintf(f,
				"%s\tCOMPREPLY=($(compgen -W \"$(_rmd_can) $(_rmd_serial) sim\" "
				"-- \"$cur\"))\n",
				in);
			break;
		case TOOL_VAL_CAN:
			fprintf(f, "%s\tCOMPREPLY=($(compgen -W \"$(_rmd_can)\" -- \"$cur\"))\n",
				in);
			break;
		case TOOL_VAL_SERIAL:
			fprintf(f, "%s\tCOMPREPLY=($(compgen -W \"$(_rmd_serial)\" -- \"$cur\"))\n",
				in);
			break;
		case TOOL_VAL_WORDS:
			fprintf(f, "%s\tCOMPREPLY=($(compgen -W \"%s\" -- \"$cur\"))\n", in,
				o[i].words ? o[i].words : "");
			break;
		case TOOL_VAL_PROTO:
		case TOOL_VAL_FIRMWARE: {
			char keys[64];

			fprintf(f, "%s\tCOMPREPLY=($(compgen -W \"%s\" -- \"$cur\"))\n", in,
				o[i].value == TOOL_VAL_PROTO ?
					rmd_proto_keys_text(keys, sizeof(keys), " ", " ") :
					rmd_firmware_keys_text(keys, sizeof(keys), " ", " "));
			break;
		}
		case TOOL_VAL_NONE:
			break;
		}
		fprintf(f, "%s\treturn\n%s\t;;\n", in, in);
	}
}

/* The option words of table o: rows listed in --help whose flag is 0 or in flags. */
static void compl_opt_words(FILE *f, const struct tool_opt *o, size_t n, unsigned flags)
{
	for (size_t i = 0; i < n; i++)
		if (o[i].help && (!o[i].flag || (o[i].flag & flags)))
			fprintf(f, " --%s", o[i].name);
}

/* One context's body: values of the previous word, then options (and files). */
static void compl_body(FILE *f, const char *in, const struct tool_opt *o, size_t n, unsigned flags,
		       const struct tool_opt *more, size_t n_more, bool files)
{
	fprintf(f, "%scase $prev in\n", in);
	compl_values(f, in, o, n, flags);
	compl_values(f, in, more, n_more, ~0u);
	fprintf(f, "%sesac\n", in);
	fprintf(f, "%sif [[ $cur == -* ]]; then\n%s\tCOMPREPLY=($(compgen -W \"", in, in);
	compl_opt_words(f, o, n, flags);
	compl_opt_words(f, more, n_more, ~0u);
	fprintf(f, "\" -- \"$cur\"))\n");
	if (files)
		fprintf(f,
			"%selse\n%s\tcompopt -o filenames 2>/dev/null\n"
			"%s\tCOMPREPLY=($(compgen -f -- \"$cur\"))\n",
			in, in, in);
	fprintf(f, "%sfi\n", in);
}

void tool_completion_bash(FILE *f, const char *prog, const struct tool_opt *opts, size_t n,
			  const struct tool_compl_cmd *cmds, size_t ncmds)
{
	char fn[64];
	size_t k;

	/* the function's name: _rmd_sim for rmd-sim */
	snprintf(fn, sizeof(fn), "_%s", prog);
	for (k = 0; fn[k]; k++)
		if (fn[k] == '-')
			fn[k] = '_';
	fprintf(f,
		"# bash completion for %s, written by `%s --completion bash` from the option\n"
		"# tables its --help prints (do not edit: the build writes it again).\n\n%s\n",
		prog, prog, compl_helpers);
	fprintf(f, "%s()\n{\n", fn);
	fprintf(f, "\tlocal cur=${COMP_WORDS[COMP_CWORD]} prev=\n"
		   "\t((COMP_CWORD > 0)) && prev=${COMP_WORDS[COMP_CWORD - 1]}\n"
		   "\tCOMPREPLY=()\n");
	if (!cmds) {
		compl_body(f, "\t", opts, n, ~0u, NULL, 0, false);
		fprintf(f, "}\n\ncomplete -F %s %s\n", fn, prog);
		return;
	}
	fprintf(f, "\tif ((COMP_CWORD == 1)); then\n\t\tCOMPREPLY=($(compgen -W \"help");
	compl_opt_words(f, opts, n, ~0u);
	for (k = 0; k < ncmds; k++)
		fprintf(f, " %s", cmds[k].name);
	fprintf(f, "\" -- \"$cur\"))\n\t\treturn\n\tfi\n");
	fprintf(f, "\tcase ${COMP_WORDS[1]} in\n\thelp)\n\t\tif ((COMP_CWORD == 2)); then\n");
	fprintf(f, "\t\t\tCOMPREPLY=($(compgen -W \"");
	for (k = 0; k < ncmds; k++)
		fprintf(f, "%s%s", k ? " " : "", cmds[k].name);
	fprintf(f, "\" -- \"$cur\"))\n\t\tfi\n\t\t;;\n");
	for (k = 0; k < ncmds; k++) {
		fprintf(f, "\t%s)\n", cmds[k].name);
		compl_body(f, "\t\t", cmds[k].opts, cmds[k].n, cmds[k].flags, cmds[k].more,
			   cmds[k].n_more, cmds[k].files);
		fprintf(f, "\t\t;;\n");
	}
	fprintf(f, "\tesac\n}\n\ncomplete -F %s %s\n", fn, prog);
}

bool tool_completion_shell(const char *prog, const char *shell)
{
	if (shell && !strcmp(shell, "bash"))
		return true;
	fprintf(stderr, "%s: --completion %s: only bash\n", prog, shell ? shell : "");
	return false;
}
