// SPDX-License-Identifier: MIT
/* The wire as candump saw it: see canlog.h. */
#define _GNU_SOURCE
#include <errno.h>
#include <fcntl.h>
#include <poll.h>
#include <pthread.h>
#include <sched.h>
#include <setjmp.h>
#include <stdarg.h>
#include <stdbool.h>
#include <stddef.h>
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <time.h>
#include <unistd.h>

#include <net/if.h>
#include <sys/socket.h>

#include <linux/can.h>
#include <linux/can/raw.h>

#include <cmocka.h>

#include "rmd/candump.h"
#include "rmd/time.h"
#include "harness/canlog.h"
#include "harness/sleeper.h"

#define NS_PER_MS INT64_C(1000000)
#define NS_PER_S INT64_C(1000000000)
#define MARKER_RESEND_MS 200

int64_t real_ns(void)
{
	struct timespec ts;

	clock_gettime(CLOCK_REALTIME, &ts);
	return (int64_t)ts.tv_sec * NS_PER_S + ts.tv_nsec;
}

void canlog_init(struct canlog *c)
{
	memset(c, 0, sizeof(*c));
	c->log_fd = -1;
	for (unsigned b = 0; b < CANLOG_BUSES; b++)
		c->can_fd[b] = -1;
}

static int bus_of_iface(const struct canlog *c, const char *name)
{
	for (unsigned b = 0; b < c->nbus; b++)
		if (!strcmp(name, c->iface[b]))
			return (int)b;
	return -1;
}

static void take_line(struct canlog *c, const char *line)
{
	struct rmd_candump_line cl;
	struct cframe *f;
	int64_t frac;
	int b;

	if (strstr(line, "DROPCOUNT")) {
		c->drop_lines++;
		snprintf(c->drop_text, sizeof(c->drop_text), "%.150s", line);
		return;
	}
	if (rmd_candump_parse(line, &cl) < 0 || !cl.has_time) {
		c->bad_lines++;
		return;
	}
	b = bus_of_iface(c, cl.iface);
	if (b < 0)
		return;
	if (cl.frame.can_id == CANLOG_MARKER_ID && cl.frame.len == 8 && cl.frame.data[0] == 'M') {
		uint32_t m;

		memcpy(&m, &cl.frame.data[4], sizeof(m));
		if (m > c->marker_seen[b])
			c->marker_seen[b] = m;
		return;
	}
	if (c->nframes == c->cap) {
		size_t cap = c->cap ? 2 * c->cap : 65536;
		struct cframe *nf = realloc(c->frames, cap * sizeof(*nf));

		assert_non_null(nf);
		c->frames = nf;
		c->cap = cap;
	}
	frac = cl.time_frac;
	for (unsigned d = cl.time_digits; d < 9; d++)
		frac *= 10;
	f = &c->frames[c->nframes++];
	f->t_ns = (int64_t)cl.time_sec * NS_PER_S + frac;
	f->id = (uint16_t)cl.frame.can_id;
	f->bus = (uint8_t)b;
	f->len = cl.frame.len;
	memcpy(f->data, cl.frame.data, sizeof(f->data));
}

void canlog_tail(struct canlog *c)
{
	if (c->log_fd < 0)
		return;
	for (;;) {
		ssize_t r = read(c->log_fd, c->lbuf + c->llen, sizeof(c->lbuf) - 1 - c->llen);
		char *p = c->lbuf, *nl;

		if (r <= 0)
			return;
		c->llen += (size_t)r;
		while ((nl = memchr(p, '\n', c->llen - (size_t)(p - c->lbuf)))) {
			*nl = '\0';
			take_line(c, p);
			p = nl + 1;
		}
		c->llen -= (size_t)(p - c->lbuf);
		memmove(c->lbuf, p, c->llen);
		if (c->llen >= sizeof(c->lbuf) - 1)
			c->llen = 0; /* a line this long is no candump line */
	}
}

void canlog_forget(struct canlog *c)
{
	c->nframes = 0;
}

int can_raw_open(const char *iface, bool receive)
{
	struct sockaddr_can addr = { .can_family = AF_CAN };
	int fd = socket(PF_CAN, SOCK_RAW | SOCK_CLOEXEC | SOCK_NONBLOCK, CAN_RAW);

	if (fd < 0)
		fail_msg("socket(PF_CAN): %s", strerror(errno));
	if (!receive)
		setsockopt(fd, SOL_CAN_RAW, CAN_RAW_FILTER, NULL, 0);
	addr.can_ifindex = (int)if_nametoindex(iface);
	if (!addr.can_ifindex || bind(fd, (struct sockaddr *)&addr, sizeof(addr)) < 0)
		fail_msg("bind %s: %s", iface, strerror(errno));
	return fd;
}

void canlog_send(struct canlog *c, unsigned b, uint32_t id, const uint8_t data[RMD_FRAME_LEN])
{
	struct can_frame cf = { .can_id = id, .len = 8 };
	ssize_t w;

	memcpy(cf.data, data, 8);
	w = write(c->can_fd[b], &cf, sizeof(cf));
	/* a socket keeps the ENETDOWN of a link that went down (rmdd restarts it): stale once up */
	if (w < 0 && errno == ENETDOWN)
		w = write(c->can_fd[b], &cf, sizeof(cf));
	if (w != (ssize_t)sizeof(cf))
		fail_msg("%s: write 0x%03X: %s", c->iface[b], (unsigned)id,
			 w < 0 ? strerror(errno) : "short write");
}

void canlog_sync(struct canlog *c, int ms, service_fn *service, struct sleeper *ref)
{
	uint8_t d[8] = { 'M', 'R', 'K' };
	int64_t now = rmd_now_ns(), end = now + ms * NS_PER_MS, resend = now;
	int64_t held0 = ref ? sleeper_held_off_ns(ref) : 0;
	uint32_t want = ++c->marker;

	memcpy(&d[4], &want, sizeof(want));
	for (;;) {
		bool all = true;

		canlog_tail(c);
		for (unsigned b = 0; b < c->nbus; b++)
			all &= c->marker_seen[b] >= want;
		if (all)
			return;
		now = rmd_now_ns();
		if (now > end)
			fail_msg(
				"candump's log %s did not show marker %u within %d ms (candump %s; "
				"the guest held a normal-priority thread off %.1f ms meanwhile); "
				"candump:\n%s",
				c->path, (unsigned)want, ms,
				c->candump && !kid_poll_exit(c->candump) ? "running" : "exited",
				ref ? (double)(sleeper_held_off_ns(ref) - held0) / 1e6 : 0.0,
				c->candump ? kid_tail(c->candump) : "");
		if (now >= resend) {
			for (unsigned b = 0; b < c->nbus; b++)
				if (c->marker_seen[b] < want)
					canlog_send(c, b, CANLOG_MARKER_ID, d);
			resend = now + MARKER_RESEND_MS * NS_PER_MS;
		}
		if (service)
			service(5);
		else
			poll(NULL, 0, 5);
	}
}

void canlog_start(struct canlog *c, const char *path, const char *const *ifaces, unsigned n,
		  int fifo, int sync_ms, service_fn *service, struct sleeper *ref)
{
	const char *argv[9 + CANLOG_BUSES];
	unsigned a = 0;

	if (n > CANLOG_BUSES)
		fail_msg("candump on %u buses: the log follows %d at most", n, CANLOG_BUSES);
	snprintf(c->path, sizeof(c->path), "%s", path);
	c->nbus = n;
	argv[a++] = "candump";
	argv[a++] = "-L";
	argv[a++] = "-d";
	argv[a++] = "-D"; /* on through an interface's restart (rmdd's, test_system_no_ack) */
	argv[a++] = "-r";
	argv[a++] = "4194304";
	for (unsigned b = 0; b < n; b++) {
		snprintf(c->iface[b], sizeof(c->iface[b]), "%s", ifaces[b]);
		argv[a++] = ifaces[b];
	}
	argv[a] = NULL;
	c->candump = kid_spawn("candump", argv, path, fifo);
	c->log_fd = open(path, O_RDONLY | O_CLOEXEC);
	if (c->log_fd < 0)
		fail_msg("%s: %s", path, strerror(errno));
	for (unsigned b = 0; b < n; b++)
		c->can_fd[b] = can_raw_open(ifaces[b], false);
	/* candump has no "ready": its first logged marker says it listens */
	canlog_sync(c, sync_ms, service, ref);
}

void canlog_free(struct canlog *c)
{
	for (unsigned b = 0; b < CANLOG_BUSES; b++)
		close_fd(&c->can_fd[b]);
	close_fd(&c->log_fd);
	free(c->frames);
	c->frames = NULL;
	c->nframes = c->cap = 0;
	c->candump = NULL;
}

struct rmd_frame canlog_ask(struct canlog *c, int rx_fd, unsigned b, uint32_t req_id,
			    const uint8_t req[RMD_FRAME_LEN], uint32_t rep_id, int ms,
			    service_fn *service)
{
	int64_t end = rmd_now_ns() + ms * NS_PER_MS;
	struct can_frame cf;
	struct rmd_frame f = { 0 };

	canlog_send(c, b, req_id, req);
	for (;;) {
		struct pollfd p = { .fd = rx_fd, .events = POLLIN };

		if (rmd_now_ns() > end)
			fail_msg("%s: no answer on 0x%03X to 0x%02X on 0x%03X within %d ms",
				 c->iface[b], (unsigned)rep_id, req[0], (unsigned)req_id, ms);
		poll(&p, 1, 10);
		while (read(rx_fd, &cf, sizeof(cf)) == (ssize_t)sizeof(cf)) {
			if (cf.can_id == rep_id && cf.len == 8 && cf.data[0] == req[0]) {
				f.can_id = cf.can_id;
				f.len = cf.len;
				memcpy(f.data, cf.data, 8);
				return f;
			}
		}
		if (service)
			service(0);
	}
}

static void *canwatch_main(void *arg)
{
	struct canwatch *w = arg;
	struct can_frame cf;

	while (!atomic_load(&w->stop)) {
		struct pollfd p = { .fd = w->fd, .events = POLLIN };

		if (poll(&p, 1, 20) <= 0)
			continue;
		while (read(w->fd, &cf, sizeof(cf)) == (ssize_t)sizeof(cf))
			if (cf.can_id == w->id && !atomic_load(&w->first_ns))
				atomic_store(&w->first_ns, real_ns());
	}
	return NULL;
}

void canwatch_start(struct canwatch *w, const char *iface, uint32_t id, int fifo)
{
	struct can_filter f = { .can_id = id,
				.can_mask = CAN_SFF_MASK | CAN_EFF_FLAG | CAN_RTR_FLAG };
	int rc;

	memset(w, 0, sizeof(*w));
	w->id = id;
	w->fd = can_raw_open(iface, true);
	if (setsockopt(w->fd, SOL_CAN_RAW, CAN_RAW_FILTER, &f, sizeof(f)) < 0)
		fail_msg("%s: CAN_RAW_FILTER 0x%03X: %s", iface, (unsigned)id, strerror(errno));
	rc = watcher_start(&w->thread, canwatch_main, w, fifo, &w->is_fifo);
	if (rc != 0)
		fail_msg("a watch of 0x%03X: pthread_create: %s", (unsigned)id, strerror(rc));
	w->started = true;
}

int64_t canwatch_first_ns(struct canwatch *w)
{
	return atomic_load(&w->first_ns);
}

void canwatch_stop(struct canwatch *w)
{
	if (watcher_stop(w->thread, &w->stop, &w->started))
		close_fd(&w->fd);
}

bool cframe_is(const struct cframe *f, unsigned b, unsigned id, int cmd, int64_t t0, int64_t t1)
{
	return f->bus == b && f->id == id && (cmd < 0 || f->data[0] == cmd) && f->t_ns >= t0 &&
	       f->t_ns < t1;
}

const struct cframe *canlog_first(const struct canlog *c, size_t from, unsigned b, unsigned id,
				  int cmd, int64_t t0, int64_t t1)
{
	const struct cframe *best = NULL;

	/* the log merges several sockets: not strictly in time order */
	for (size_t i = from; i < c->nframes; i++)
		if (cframe_is(&c->frames[i], b, id, cmd, t0, t1) &&
		    (!best || c->frames[i].t_ns < best->t_ns))
			best = &c->frames[i];
	return best;
}

const struct cframe *canlog_last(const struct canlog *c, size_t from, unsigned b, unsigned id,
				 int cmd, int64_t t0, int64_t t1)
{
	const struct cframe *best = NULL;

	for (size_t i = from; i < c->nframes; i++)
		if (cframe_is(&c->frames[i], b, id, cmd, t0, t1) &&
		    (!best || c->frames[i].t_ns >= best->t_ns))
			best = &c->frames[i];
	return best;
}

unsigned canlog_count(const struct canlog *c, size_t from, unsigned b, unsigned id, int cmd,
		      int64_t t0, int64_t t1)
{
	unsigned n = 0;

	for (size_t i = from; i < c->nframes; i++)
		n += cframe_is(&c->frames[i], b, id, cmd, t0, t1);
	return n;
}
