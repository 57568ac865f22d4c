// SPDX-License-Identifier: MIT
/*
 * systemd's notification protocol through libsystemd (sd_notify(3)):
 * READY=1 after bring-up, STATUS= with a one-line summary, WATCHDOG=1 while
 * the rt loop's heartbeat advances (the caller decides; a stuck loop stops
 * the pings and systemd restarts the service), STOPPING=1 on the way out.
 * Without NOTIFY_SOCKET in the environment (not started by systemd)
 * nothing is sent.  Non-rt.
 */
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include <systemd/sd-daemon.h>

#include "rmdd.h"

void rmdd_notify_init(struct rmdd_notify *n)
{
	uint64_t usec = 0;
	const char *sock = getenv("NOTIFY_SOCKET");

	n->active = sock && sock[0];
	n->watchdog_ns = 0;
	n->ping_every_ns = 0;
	/* > 0 only when WATCHDOG_USEC is set and WATCHDOG_PID, if set, is us */
	if (n->active && sd_watchdog_enabled(0, &usec) > 0 && usec > 0) {
		n->watchdog_ns = (int64_t)usec * 1000;
		n->ping_every_ns = n->watchdog_ns / 2;
	}
}

static void send_state(const struct rmdd_notify *n, const char *head, const char *status)
{
	char msg[512];
	int r;

	if (!n->active)
		return;
	if (status)
		snprintf(msg, sizeof(msg), "%s%sSTATUS=%s", head, head[0] ? "\n" : "", status);
	else
		snprintf(msg, sizeof(msg), "%s", head);
	r = sd_notify(0, msg);
	if (r < 0)
		tool_log(7, "sd_notify: %s", strerror(-r));
}

void rmdd_notify_ready(const struct rmdd_notify *n, const char *status)
{
	send_state(n, "READY=1", status);
}

void rmdd_notify_status(const struct rmdd_notify *n, const char *status)
{
	send_state(n, "", status);
}

void rmdd_notify_watchdog(const struct rmdd_notify *n)
{
	if (n->watchdog_ns)
		send_state(n, "WATCHDOG=1", NULL);
}

void rmdd_notify_stopping(const struct rmdd_notify *n, const char *status)
{
	send_state(n, "STOPPING=1", status);
}
