/* SPDX-License-Identifier: MIT */
#define _GNU_SOURCE
#include "pty_probe.h"

#include <errno.h>
#include <fcntl.h>
#include <poll.h>
#include <stdlib.h>
#include <termios.h>
#include <time.h>
#include <unistd.h>

static int64_t mono_ns(void)
{
	struct timespec ts;

	clock_gettime(CLOCK_MONOTONIC, &ts);
	return (int64_t)ts.tv_sec * 1000000000 + ts.tv_nsec;
}

static void keep_worst(atomic_llong *w, int64_t v)
{
	long long old = atomic_load(w);

	while (v > old && !atomic_compare_exchange_weak(w, &old, v))
		;
}

static void *probe_main(void *arg)
{
	struct pty_probe *p = arg;
	int64_t next = mono_ns();

	while (!atomic_load(&p->stop)) {
		struct pollfd pfd = { .fd = p->slave, .events = POLLIN };
		struct timespec ts;
		int64_t t0 = mono_ns(), hop;
		char buf[64];

		atomic_store(&p->inflight_ns, t0);
		if (write(p->master, "x", 1) != 1)
			break;
		/* until it arrives; every 100 ms a look at stop */
		while (!atomic_load(&p->stop) && poll(&pfd, 1, 100) == 0)
			;
		if (atomic_load(&p->stop))
			break;
		while (read(p->slave, buf, sizeof(buf)) > 0)
			;
		hop = mono_ns() - t0;
		atomic_store(&p->inflight_ns, 0);
		keep_worst(&p->worst_ns, hop);
		keep_worst(&p->total_worst_ns, hop);
		atomic_fetch_add(&p->hops, 1);
		next += p->period_ns;
		if (next < mono_ns())
			next = mono_ns();
		ts.tv_sec = next / 1000000000;
		ts.tv_nsec = next % 1000000000;
		clock_nanosleep(CLOCK_MONOTONIC, TIMER_ABSTIME, &ts, NULL);
	}
	atomic_store(&p->inflight_ns, 0);
	return NULL;
}

int pty_probe_start(struct pty_probe *p, int64_t period_ns)
{
	struct termios t;
	int r;

	*p = (struct pty_probe){ .period_ns = period_ns, .master = -1, .slave = -1 };
	p->master = posix_openpt(O_RDWR | O_NOCTTY | O_CLOEXEC);
	if (p->master < 0 || grantpt(p->master) < 0 || unlockpt(p->master) < 0)
		goto err;
	p->slave = open(ptsname(p->master), O_RDWR | O_NOCTTY | O_NONBLOCK | O_CLOEXEC);
	if (p->slave < 0 || tcgetattr(p->slave, &t) < 0)
		goto err;
	cfmakeraw(&t);
	if (tcsetattr(p->slave, TCSANOW, &t) < 0)
		goto err;
	r = pthread_create(&p->thread, NULL, probe_main, p);
	if (r) {
		errno = r;
		goto err;
	}
	p->started = true;
	return 0;

err:
	r = -errno;
	if (p->slave >= 0)
		close(p->slave);
	if (p->master >= 0)
		close(p->master);
	p->master = p->slave = -1;
	return r;
}

void pty_probe_mark(struct pty_probe *p)
{
	atomic_store(&p->worst_ns, 0);
	atomic_store(&p->hops, 0);
}

int64_t pty_probe_worst_ns(struct pty_probe *p)
{
	int64_t w = atomic_load(&p->worst_ns), sent = atomic_load(&p->inflight_ns);

	if (sent && mono_ns() - sent > w)
		w = mono_ns() - sent;
	return w;
}

void pty_probe_stop(struct pty_probe *p)
{
	if (!p->started)
		return;
	atomic_store(&p->stop, true);
	pthread_join(p->thread, NULL);
	close(p->slave);
	close(p->master);
	p->started = false;
}
