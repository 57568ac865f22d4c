/* SPDX-License-Identifier: MIT */
/*
 * rmdctl top's internals, shared by top.c (options, LCM, the plain table
 * and JSON) and top_screen.c (the ncurses screen of a terminal).  Non-rt.
 */
#ifndef RMDCTL_TOP_H
#define RMDCTL_TOP_H

#include <signal.h>
#include <stdbool.h>
#include <stdint.h>

#include <lcm/lcm.h>

#include "rmd/rmd_config_t.h"
#include "rmd/rmd_health_t.h"
#include "rmd/rmd_state_t.h"

#define TOP_CHANNEL_LEN 96
/* "STALE": no health_t or state_t for this long (rmdd publishes health at 10 Hz). */
#define TOP_STALE_NS INT64_C(1000000000)

struct top {
	const char *url, *prefix;
	bool json, once, tty;
	double interval_ms, wait_s;

	lcm_t *lcm;
	char ch_state[TOP_CHANNEL_LEN], ch_health[TOP_CHANNEL_LEN], ch_config[TOP_CHANNEL_LEN],
		ch_request[TOP_CHANNEL_LEN];
	rmd_config_t *cfg; /* the newest of each (copies), NULL until one came */
	rmd_health_t *health;
	rmd_state_t *state;
	int64_t cfg_rx_ns, health_rx_ns, state_rx_ns;
	uint64_t n_states;
	int64_t next_ask_ns; /* the next config_t request while none came */
	/*
	 * The screen's pause: the view is kept, messages are received and
	 * dropped, but their times still count, so STALE stays true news.
	 */
	bool paused;
	/*
	 * One daemon per prefix (docs/lcm.md): top shows the first instance
	 * heard (config_t or health_t) and never switches; another one's
	 * config_t and health_t are kept aside as `other` and flag the view
	 * (state_t names no instance: it may mix both).
	 */
	int64_t instance; /* 0 until one is heard */
	bool mixed;
	int64_t other_instance;
	int32_t other_pid;
	char other_host[64], other_source[256];
};

/* Set by SIGINT and SIGTERM: every loop of top ends. */
extern volatile sig_atomic_t rmdctl_top_stop;

/* Ask for config_t when none came and the last request is 500 ms old. */
void top_ask_config_due(struct top *t);
/* The state's motor i, or NULL when state_t has none at that index. */
const rmd_motor_state_t *top_motor_state(const struct top *t, int i);
/* Names of a state_t mode and a health_t bus state; "?" when unknown. */
const char *top_mode_name(int mode);
const char *top_bus_state_name(int s);
/* Another daemon's line: "MIXED: ..." naming both instances (t->mixed). */
void top_mixed_line(const struct top *t, char *buf, size_t len);
/* No health_t or state_t for TOP_STALE_NS. */
bool top_stale(const struct top *t);

/*
 * The live view on a terminal with ncurses until q, Ctrl-C or SIGTERM.
 * Returns 0, -EIO when LCM failed, or -ENOTTY when curses cannot drive
 * this terminal (the caller prints plain tables instead).
 */
int top_screen_run(struct top *t);

#endif /* RMDCTL_TOP_H */
