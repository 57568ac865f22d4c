// SPDX-License-Identifier: MIT
/*
 * rmdd's monitor thread (it logs through tools/common/log.h: one line per
 * call on stderr, "<N>rmdd: ..." with the syslog level N, STYLE.md).
 *
 * The monitor is a normal-priority thread that sleeps until the rt loop
 * writes its eventfd (at the end of a cycle that pushed events; issue 11:
 * no polling) and then drains the loop's event ring and logs each event
 * as its kind's row in events.c words it, with its context ("can0: motor
 * 3 (knee_l): lost (10 missed replies in a row)"); the loop sends events
 * only on change, and overruns are summed up to one line every RMDD_OVERRUN_SUMMARY_S here
 * (the only timed wake-up, while a summary is open).  Reply latencies are
 * the loop's own (rmd_loop_get_reply_latency()).  Everything here is
 * non-rt.
 */
#define _GNU_SOURCE /* pthread_setname_np */
#include <errno.h>
#include <inttypes.h>
#include <poll.h>
#include <string.h>
#include <time.h>
#include <unistd.h>

#include <sys/eventfd.h>

#include "rmd/time.h"
#include "rmd/thread.h"
#include "rmdd.h"

/* ---- events ---------------------------------------------------------------- */

/* Log e by its row (events.c), and tell the incident writer when it is a safety event. */
static void log_event(struct rmdd_monitor *m, const struct rmd_event *e)
{
	char line[RMDD_EVENT_LINE_LEN];
	int level = rmdd_event_journal(&m->notes, e, line, sizeof(line));

	if (level > 0)
		tool_log(level, "%s", line);
	if (m->incidents) {
		const char *kind;
		char what[160];

		if (rmdd_incident_kind(m->cfg, e, what, sizeof(what), &kind))
			rmdd_incidents_trigger(m->incidents, e->t_ns, kind, what, false);
	}
}

/* Every RMDD_OVERRUN_SUMMARY_S: the overruns that followed the first one. */
static void overrun_summary(struct rmdd_monitor *m, int64_t now)
{
	char line[RMDD_EVENT_LINE_LEN];
	int level = rmdd_event_overruns(&m->notes, now, line, sizeof(line));

	if (level > 0)
		tool_log(level, "%s", line);
}

void rmdd_monitor_drain(struct rmdd_monitor *m)
{
	char line[RMDD_EVENT_LINE_LEN];
	struct rmd_event e;
	uint64_t dropped;
	int level;

	while (rmd_ring_pop(m->events, &e))
		log_event(m, &e);
	while ((level = rmdd_event_rt_lines(&m->notes, line, sizeof(line))) > 0)
		tool_log(level, "%s", line);
	dropped = rmd_ring_dropped(m->events);
	if (dropped != m->ring_dropped) {
		tool_log(4, "%" PRIu64 " rt loop event(s) lost: the ring was full",
			 dropped - m->ring_dropped);
		m->ring_dropped = dropped;
	}
}

/* ---- the thread ----------------------------------------------------------------- */

/*
 * The wait until there is something to do: the loop's event eventfd (or
 * a stop) without a timeout; with overruns summed up, until the end of
 * their RMDD_OVERRUN_SUMMARY_S window.
 */
static int monitor_wait(struct rmdd_monitor *m)
{
	struct pollfd pfd[2] = {
		{ .fd = m->stop_fd, .events = POLLIN },
		{ .fd = m->wake_fd, .events = POLLIN },
	};
	struct timespec ts, *tsp = NULL;

	if (m->notes.overruns_logged) {
		int64_t left = m->notes.overrun_window_ns + RMDD_OVERRUN_SUMMARY_S * RMD_NS_PER_S -
			       rmd_now_ns();

		if (left < 0)
			left = 0;
		ts.tv_sec = left / RMD_NS_PER_S;
		ts.tv_nsec = left % RMD_NS_PER_S;
		tsp = &ts;
	}
	if (ppoll(pfd, 2, tsp, NULL) < 0 && errno != EINTR)
		return -errno;
	if (pfd[0].revents & POLLIN)
		return 1;
	if (pfd[1].revents & POLLIN) {
		uint64_t v;

		if (read(m->wake_fd, &v, sizeof(v)) < 0) {
			/* EAGAIN: another read took it */
		}
	}
	return 0;
}

static void *monitor_main(void *arg)
{
	struct rmdd_monitor *m = arg;

	pthread_setname_np(pthread_self(), "rmdd-monitor");
	for (;;) {
		if (monitor_wait(m) != 0)
			break;
		rmdd_monitor_drain(m);
		overrun_summary(m, rmd_now_ns());
	}
	return NULL;
}

int rmdd_monitor_init(struct rmdd_monitor *m, const struct rmd_config *cfg, struct rmd_loop *loop,
		      struct rmd_ring *events)
{
	int r;

	memset(m, 0, sizeof(*m));
	m->cfg = cfg;
	m->loop = loop;
	m->events = events;
	m->wake_fd = -1;
	rmdd_event_notes_init(&m->notes, cfg);
	m->stop_fd = eventfd(0, EFD_CLOEXEC | EFD_NONBLOCK);
	if (m->stop_fd < 0)
		return -errno;
	m->wake_fd = eventfd(0, EFD_CLOEXEC | EFD_NONBLOCK);
	if (m->wake_fd < 0) {
		r = -errno;
		close(m->stop_fd);
		m->stop_fd = -1;
		return r;
	}
	/* the loop writes it in a cycle that pushed events: the monitor sleeps otherwise */
	rmd_loop_set_events_fd(loop, m->wake_fd);
	return 0;
}

int rmdd_monitor_start(struct rmdd_monitor *m)
{
	int r;

	if (m->running)
		return -EALREADY;
	r = rmd_thread_start_normal(&m->thread, monitor_main, m);
	if (!r)
		m->running = true;
	return r;
}

void rmdd_monitor_stop(struct rmdd_monitor *m)
{
	uint64_t one = 1;

	if (m->running) {
		if (write(m->stop_fd, &one, sizeof(one)) < 0) {
			/* only on overflow: already signalled */
		}
		pthread_join(m->thread, NULL);
		m->running = false;
	}
	rmdd_monitor_drain(m);
	overrun_summary(m, INT64_MAX);
}

void rmdd_monitor_fini(struct rmdd_monitor *m)
{
	rmdd_monitor_stop(m);
	if (m->stop_fd >= 0)
		close(m->stop_fd);
	m->stop_fd = -1;
	if (m->wake_fd >= 0) {
		rmd_loop_set_events_fd(m->loop, -1);
		close(m->wake_fd);
	}
	m->wake_fd = -1;
}
