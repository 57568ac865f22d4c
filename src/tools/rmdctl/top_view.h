/* SPDX-License-Identifier: MIT */
/*
 * What rmdctl top shows: the newest config_t, health_t and state_t that
 * top.c received, and the names and checks that its plain table, its JSON
 * and the terminal screen (top_screen.c) read from them.  top.c fills the
 * record; the views only read it.  Non-rt.
 */
#ifndef RMDCTL_TOP_VIEW_H
#define RMDCTL_TOP_VIEW_H

#include <stdbool.h>
#include <stddef.h>
#include <stdint.h>

#include "rmd/rmd_config_t.h"
#include "rmd/rmd_health_t.h"
#include "rmd/rmd_state_t.h"

/* "STALE": no health_t or state_t for this long (rmdd publishes health at 10 Hz). */
#define TOP_STALE_NS INT64_C(1000000000)

struct top_view {
	const char *url, *prefix;
	rmd_config_t *cfg; /* the newest of each (copies), NULL until one came */
	rmd_health_t *health;
	rmd_state_t *state;
	int64_t cfg_rx_ns, health_rx_ns, state_rx_ns;
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

/*
 * What the view's daemon is called: its robot.instance (config_t, else
 * health_t) when it has one, else the channel prefix it was opened with.
 */
const char *top_instance_name(const struct top_view *v);

/* The state's motor i, or NULL when state_t has none at that index. */
const rmd_motor_state_t *top_motor_state(const struct top_view *v, int i);
/* Names of a state_t mode and a health_t bus state; "?" when unknown. */
const char *top_mode_name(int mode);
const char *top_bus_state_name(int s);
/* Another daemon's line: "MIXED: ..." naming both instances (v->mixed). */
void top_mixed_line(const struct top_view *v, char *buf, size_t len);
/* No health_t or state_t for TOP_STALE_NS. */
bool top_stale(const struct top_view *v);
/* No health_t for TOP_STALE_NS (or none ever): the daemon is silent. */
bool top_silent(const struct top_view *v);

#endif /* RMDCTL_TOP_VIEW_H */
