// SPDX-License-Identifier: MIT
/*
 * The baseline of bench/vs-blocking.sh: what common RMD drivers do (e.g.
 * 2b-t/myactuator_rmd), a strictly sequential request -> wait-for-reply
 * loop.  Each cycle sends one motor its request, blocks until that motor's
 * reply (or a timeout), then goes to the next motor; a cycle is done when
 * every motor of the configuration has been served once.  It runs as fast
 * as it can for SECONDS and prints the achieved rate (cycles a second).
 *
 *   blocking_driver CONFIG.yaml SECONDS [--threads] [--cmd 0x9C] [--timeout-us T]
 *                   [--step-us S]
 *
 * The motors and buses are those of rmdd's CONFIG.yaml, and the request is
 * the one rmdd sends a READY motor every cycle (V3 §2.13 0x9C status 2),
 * built and decoded with the project's codec, so the frames are the same.
 *   sim buses:       opened as rmdd opens them (rmd_bus_open); the sim bus
 *                    has no descriptor and its time advances with the
 *                    caller's clock, so the driver looks at it every S us
 *                    (default 20; 0: busy-waits), sleeping between looks as
 *                    a blocking read sleeps until the reply wakes it.
 *   socketcan buses: a plain CAN_RAW socket on the bus's interface, write(),
 *                    then poll() + read() until the reply or the timeout.
 * --threads: one thread a bus, each sequential over its own motors, and a
 * barrier at the end of each cycle (every motor once a cycle); without it
 * one thread serves the buses one after the other, as those drivers do.
 * A reply not there by the timeout (default 5000 us) is missed, and the
 * driver goes on to the next motor.  Exit 0 when no reply was missed.
 *
 * Non-rt, a benchmark.
 */
#include <errno.h>
#include <linux/can.h>
#include <linux/can/raw.h>
#include <net/if.h>
#include <poll.h>
#include <pthread.h>
#include <stdbool.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/socket.h>
#include <time.h>
#include <unistd.h>

#include "rmd/bus.h"
#include "rmd/bus_open.h"
#include "rmd/codec.h"
#include "rmd/config.h"
#include "rmd/config_yaml.h"
#include "rmd/sim_setup.h"
#include "rmd/time.h"
#include "rmd/txn.h"

struct bmotor {
	struct rmd_txn t; /* the request, and the identifier and command byte of its reply */
	enum rmd_proto proto;
};

struct bbus {
	struct rmd_bus bus; /* sim */
	int fd;		    /* socketcan: CAN_RAW socket, else -1 */
	struct bmotor *m[RMD_MAX_MOTORS];
	unsigned n;
};

/* One worker: its buses, served one after the other, and its counts. */
struct worker {
	pthread_t th;
	struct bbus *b[RMD_MAX_BUSES];
	unsigned nb;
	uint64_t requests, replies, missed;
	int64_t wait_sum_ns, wait_max_ns;
	int err;
};

static struct rmd_config cfg;
static struct rmd_sim_setup sim;
static struct bmotor motors[RMD_MAX_MOTORS];
static struct bbus buses[RMD_MAX_BUSES];
static struct worker workers[RMD_MAX_BUSES];
static pthread_barrier_t cycle_end;
static uint64_t stop_at; /* the last cycle, 0: not yet */
static bool failed;
static int64_t timeout_ns = 5000000;
static uint64_t cycles;
static unsigned n_workers = 1;
static int64_t end_ns;
static long step_ns = 20000; /* sim bus: sleep between looks (--step-us) */

static int can_open(const char *ifname)
{
	struct sockaddr_can addr = { .can_family = AF_CAN };
	int fd = socket(PF_CAN, SOCK_RAW, CAN_RAW);

	if (fd < 0)
		return -errno;
	addr.can_ifindex = (int)if_nametoindex(ifname);
	if (!addr.can_ifindex || bind(fd, (struct sockaddr *)&addr, sizeof(addr)) < 0) {
		int r = addr.can_ifindex ? -errno : -ENODEV;

		close(fd);
		return r;
	}
	return fd;
}

/*
 * The next frame from bus b by `deadline`: 1, 0 on timeout, or -errno.
 * The bus is looked at once more at the deadline, so a driver that was
 * scheduled out does not miss a reply that came meanwhile.
 */
static int recv_one(struct bbus *b, struct rmd_frame *f, int64_t deadline)
{
	for (;;) {
		int64_t t = rmd_now_ns();

		if (b->fd >= 0) {
			struct pollfd p = { .fd = b->fd, .events = POLLIN };
			int ms = t < deadline ? (int)((deadline - t + 999999) / 1000000) : 0;
			struct can_frame cf;

			if (poll(&p, 1, ms) < 0 && errno != EINTR)
				return -errno;
			if (p.revents & POLLIN) {
				if (read(b->fd, &cf, sizeof(cf)) != (ssize_t)sizeof(cf))
					return -EIO;
				f->can_id = cf.can_id & CAN_SFF_MASK;
				f->len = cf.len;
				memcpy(f->data, cf.data, sizeof(f->data));
				return 1;
			}
		} else {
			struct rmd_bus_rx rx;
			int r = rmd_bus_recv(&b->bus, &rx, 1, t);

			if (r)
				return r < 0 ? r : (*f = rx.f, 1);
			if (t < deadline && step_ns) {
				struct timespec ts = { .tv_nsec = step_ns };

				nanosleep(&ts, NULL);
			}
		}
		if (t >= deadline)
			return 0;
	}
}

static int send_one(struct bbus *b, const struct rmd_frame *f)
{
	if (b->fd >= 0) {
		struct can_frame cf = { .can_id = f->can_id, .len = f->len };

		memcpy(cf.data, f->data, sizeof(cf.data));
		return write(b->fd, &cf, sizeof(cf)) == (ssize_t)sizeof(cf) ? 0 : -errno;
	}
	return rmd_bus_send(&b->bus, f, 1, rmd_now_ns()) == 1 ? 0 : -EAGAIN;
}

/* Send m its request and block until its reply or the timeout: the common driver's step. */
static int transact(struct worker *w, struct bbus *b, struct bmotor *m)
{
	int64_t t0 = rmd_now_ns(), deadline = t0 + timeout_ns;
	struct rmd_frame f;
	struct rmd_msg msg;
	int r = send_one(b, &m->t.req);

	if (r)
		return r;
	w->requests++;
	while ((r = recv_one(b, &f, deadline)) > 0) {
		if (!rmd_txn_matches(&m->t, &f))
			continue;
		if (rmd_decode(m->proto, RMD_DIR_REPLY, &f, &msg, NULL) == 0)
			w->replies++;
		t0 = rmd_now_ns() - t0;
		w->wait_sum_ns += t0;
		if (t0 > w->wait_max_ns)
			w->wait_max_ns = t0;
		return 0;
	}
	if (r == 0)
		w->missed++;
	return r;
}

/*
 * Serve w's motors one after the other, cycle after cycle.  Worker 0 names
 * the last cycle (stop_at) before the barrier that ends it; every worker
 * stops after that cycle's barrier, so none is left waiting at the next.
 */
static void *work(void *arg)
{
	struct worker *w = arg;

	for (uint64_t c = 1;; c++) {
		for (unsigned i = 0; i < w->nb && !w->err; i++)
			for (unsigned k = 0; k < w->b[i]->n && !w->err; k++)
				w->err = transact(w, w->b[i], w->b[i]->m[k]);
		if (w->err)
			__atomic_store_n(&failed, true, __ATOMIC_RELAXED);
		if (w == &workers[0]) {
			cycles = c;
			if (rmd_now_ns() >= end_ns || __atomic_load_n(&failed, __ATOMIC_RELAXED))
				__atomic_store_n(&stop_at, c, __ATOMIC_RELEASE);
		}
		if (n_workers > 1)
			pthread_barrier_wait(&cycle_end);
		uint64_t last = __atomic_load_n(&stop_at, __ATOMIC_ACQUIRE);

		if (last && c >= last)
			return NULL;
	}
}

static int open_bus(unsigned i, char *err, size_t errlen)
{
	const struct rmd_config_bus *cb = &cfg.buses[i];
	struct rmd_bus_open_motor ms[RMD_MAX_MOTORS];
	struct rmd_bus_open_ctx ctx;

	buses[i].fd = -1;
	if (cb->kind == RMD_BUS_KIND_SOCKETCAN) {
		buses[i].fd = can_open(cb->interface);
		if (buses[i].fd < 0)
			snprintf(err, errlen, "%s: %s", cb->interface, strerror(-buses[i].fd));
		return buses[i].fd < 0 ? -1 : 0;
	}
	if (cb->kind != RMD_BUS_KIND_SIM) {
		snprintf(err, errlen, "%s: only sim and socketcan buses", cb->name);
		return -1;
	}
	rmd_bus_open_ctx_of(&cfg, &sim, i, ms, &ctx);
	return rmd_bus_open(&buses[i].bus, cb, &ctx, err, errlen) < 0 ? -1 : 0;
}

int main(int argc, char **argv)
{
	struct rmd_msg req = { .cmd = 0x9C };
	bool threads = false;
	double seconds;
	int64_t t0, t1;
	char err[2048];
	uint64_t rq = 0, rp = 0, ms = 0;
	int64_t wsum = 0, wmax = 0;

	if (argc < 3) {
		fprintf(stderr, "usage: blocking_driver CONFIG.yaml SECONDS [--threads] "
				"[--cmd 0x9C] [--timeout-us T] [--step-us S]\n");
		return 2;
	}
	seconds = atof(argv[2]);
	for (int a = 3; a < argc; a++) {
		if (!strcmp(argv[a], "--threads"))
			threads = true;
		else if (!strcmp(argv[a], "--cmd") && a + 1 < argc)
			req.cmd = (uint8_t)strtoul(argv[++a], NULL, 0);
		else if (!strcmp(argv[a], "--step-us") && a + 1 < argc)
			step_ns = atol(argv[++a]) * 1000;
		else if (!strcmp(argv[a], "--timeout-us") && a + 1 < argc)
			timeout_ns = atoll(argv[++a]) * 1000;
		else {
			fprintf(stderr, "blocking_driver: unknown argument %s\n", argv[a]);
			return 2;
		}
	}
	if (rmd_config_load(argv[1], &cfg, &sim, err, sizeof(err))) {
		fprintf(stderr, "blocking_driver: %s: %s\n", argv[1], err);
		return 1;
	}
	for (unsigned i = 0; i < cfg.n_buses; i++) {
		if (open_bus(i, err, sizeof(err))) {
			fprintf(stderr, "blocking_driver: bus %s: %s\n", cfg.buses[i].name, err);
			return 1;
		}
	}
	for (unsigned i = 0; i < cfg.n_motors; i++) {
		struct bbus *b = &buses[cfg.motors[i].bus];

		motors[i].proto = cfg.motors[i].proto;
		if (rmd_txn_prepare(&motors[i].t, motors[i].proto, cfg.motors[i].id, &req)) {
			fprintf(stderr, "blocking_driver: cannot encode 0x%02X\n", req.cmd);
			return 1;
		}
		b->m[b->n++] = &motors[i];
	}
	/* one worker a bus that has motors (--threads), or one for all */
	for (unsigned i = 0, nw = 0; i < cfg.n_buses; i++) {
		struct worker *w = &workers[threads ? nw : 0];

		if (!buses[i].n)
			continue;
		w->b[w->nb++] = &buses[i];
		if (threads)
			n_workers = ++nw;
	}
	if (threads && n_workers > 1)
		pthread_barrier_init(&cycle_end, NULL, n_workers);
	t0 = rmd_now_ns();
	end_ns = t0 + (int64_t)(seconds * 1e9);
	for (unsigned i = 1; i < n_workers; i++)
		pthread_create(&workers[i].th, NULL, work, &workers[i]);
	work(&workers[0]);
	t1 = rmd_now_ns();
	for (unsigned i = 1; i < n_workers; i++)
		pthread_join(workers[i].th, NULL);
	for (unsigned i = 0; i < n_workers; i++) {
		if (workers[i].err)
			fprintf(stderr, "blocking_driver: %s\n", strerror(-workers[i].err));
		rq += workers[i].requests;
		rp += workers[i].replies;
		ms += workers[i].missed;
		wsum += workers[i].wait_sum_ns;
		if (workers[i].wait_max_ns > wmax)
			wmax = workers[i].wait_max_ns;
	}
	printf("blocking_driver: motors %u buses %u threads %u seconds %.3f cycles %llu "
	       "rate_hz %.1f requests %llu replies %llu missed %llu reply_mean_us %.1f "
	       "reply_max_us %.1f\n",
	       cfg.n_motors, cfg.n_buses, n_workers, (t1 - t0) / 1e9, (unsigned long long)cycles,
	       cycles / ((t1 - t0) / 1e9), (unsigned long long)rq, (unsigned long long)rp,
	       (unsigned long long)ms, rp ? wsum / 1e3 / (double)rp : 0.0, wmax / 1e3);
	for (unsigned i = 0; i < cfg.n_buses; i++) {
		if (buses[i].fd >= 0)
			close(buses[i].fd);
		else
			rmd_bus_close(&buses[i].bus);
	}
	return workers[0].err || ms ? 1 : 0;
}
