/* SPDX-License-Identifier: MIT */
/*
 * rmdctl internals: the subcommand table's entries and the helpers the
 * subcommands share.  Everything here is non-rt (a command-line tool).
 */
#ifndef RMDCTL_H
#define RMDCTL_H

#include <stdbool.h>
#include <stddef.h>
#include <stdio.h>

#include "rmd/codec.h"
#include "rmd/mit.h"
#include "tools/common/log.h"

/* Exit statuses of every subcommand (printed by `rmdctl --help`). */
enum {
	RMDCTL_EXIT_OK = 0,    /* everything worked */
	RMDCTL_EXIT_DATA = 1,  /* bad input data, I/O error, or a codec refusal */
	RMDCTL_EXIT_USAGE = 2, /* bad command line */
};

/* One subcommand: `rmdctl NAME ARGS...` calls run(argc, argv) with argv[0] == NAME. */
struct rmdctl_cmd {
	const char *name;
	const char *summary;
	int (*run)(int argc, char **argv);
	void (*usage)(FILE *f);
};

int rmdctl_decode_run(int argc, char **argv);
void rmdctl_decode_usage(FILE *f);
int rmdctl_encode_run(int argc, char **argv);
void rmdctl_encode_usage(FILE *f);

/* Device commands (rmdctl_dev.c): one run for all, argv[0] picks the command. */
int rmdctl_dev_run(int argc, char **argv);
void rmdctl_scan_usage(FILE *f);
void rmdctl_info_usage(FILE *f);
void rmdctl_status_usage(FILE *f);
void rmdctl_monitor_usage(FILE *f);
void rmdctl_set_id_usage(FILE *f);
void rmdctl_set_zero_usage(FILE *f);
void rmdctl_set_timeout_usage(FILE *f);
void rmdctl_accel_usage(FILE *f);
void rmdctl_pid_usage(FILE *f);
void rmdctl_brake_usage(FILE *f);
void rmdctl_stop_usage(FILE *f);
void rmdctl_off_usage(FILE *f);
void rmdctl_reset_usage(FILE *f);
void rmdctl_move_usage(FILE *f);

/* A whole-string finite number (C locale).  Returns 0 or -EINVAL. */
int rmdctl_parse_double(const char *s, double *v);

#endif /* RMDCTL_H */
