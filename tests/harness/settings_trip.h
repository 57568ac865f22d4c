/* SPDX-License-Identifier: MIT */
/*
 * `rmdctl dump` -> edit -> `rmdctl restore` -> `rmdctl dump` on motors that
 * keep their settings between rmdctl runs (rmd-sim on a pty, or on vcan in
 * the guest), for the suites that drive rmdctl on such a line: each runs
 * rmdctl its own way, through run().  Motors 1 and 2 must answer, with
 * rmd-sim's defaults, and get them back at the end.
 */
#ifndef RMD_TESTS_SETTINGS_TRIP_H
#define RMD_TESTS_SETTINGS_TRIP_H

/*
 * Run rmdctl with args (argv[1..], NULL-terminated); *status, and its
 * stdout and stderr (valid until the next call).
 */
typedef void settings_run_fn(void *ctx, const char *const *args, int *status, const char **out,
			     const char **err);

/*
 * The round trip; bus_args (NULL-terminated, e.g. "--bus", "vcan0") end
 * every command line; its two files go to dir (removed at the end).
 * Fails the test on any difference.
 */
void settings_round_trip(settings_run_fn *run, void *ctx, const char *const *bus_args,
			 const char *dir);

/*
 * The same for V4 motors (bus_args must say --protocol v4): seven float
 * gains by index (V4.2 §2.1), one edited to a value a binary32 rounds,
 * restored and dumped back exactly; the file refused for --protocol v3.
 */
void settings_round_trip_v4(settings_run_fn *run, void *ctx, const char *const *bus_args,
			    const char *const *v3_bus_args, const char *dir);

#endif /* RMD_TESTS_SETTINGS_TRIP_H */
