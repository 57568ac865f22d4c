// SPDX-License-Identifier: MIT
/*
 * rmdctl rtt: each motor's round trip on a bus, and the loop rate the bus
 * supports with it (issue 21: real adapters, real timing).  Non-rt.
 *
 * A round trip is from the request's send (struct rmd_txn.first_sent_ns)
 * to its answer's receive stamp (rep.t_ns): the frames' wire time, the
 * motor's turnaround and whatever the adapter adds (a USB-CAN adapter's
 * 1 ms packets, a USB-RS485 converter's latency timer).  Only first tries
 * count: a resent request's answer could be the first try's, late.
 *
 * The reads are harmless and their answers differ by command class, so
 * each is measured: 0x9A status 1 (V3 §2.12, V2 §3.31), 0x9C status 2
 * (V3 §2.14, V2 §3.33: the layout of the control replies) and 0x92
 * multi-turn angle (V3 §2.11, V2 §3.29).  One request is outstanding per
 * motor at a time; as the rt loop sends them, a CAN bus carries one
 * request of every motor at once, a half-duplex line one after the other.
 *
 * A motor left pushing the reply of one of them unasked (V4.2 §2.33: 0xB6
 * active reply, set by another tool) does not answer that read, and each
 * push would pass for an answer: rtt first listens RTT_LISTEN_MS to a
 * quiet bus, and a command a motor pushes is not measured on it, said so.
 *
 * The supported rate is the planner's arithmetic (rmd/plan.h) with the
 * measured p99 in place of the assumed turnaround, one request per motor
 * per cycle, and the rule that every reply arrives before the next cycle:
 *
 *   CAN:   max(wire time of 2N worst-case frames, the largest p99)
 *   RS485: N requests in series, each paying its round trip: N * p99
 *          (the planner's 2N frames + N turnarounds, turnaround = p99 - 2 frames)
 */
#include <errno.h>
#include <inttypes.h>
#include <math.h>
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "rmd/time.h"
#include "rmd/bus_open.h"
#include "rmd/can_timing.h"
#include "rmd/codec.h"
#include "rmd/plan.h"
#include "rmd/txn.h"
#include "rmdctl.h"

/* Wait per try when --timeout is not given: a 16 ms latency timer and slow firmware fit. */
#define RTT_TIMEOUT_MS 100.0
/* Listening before the first request: pushes every n x 10 ms (V4.2 §2.33) show in it. */
#define RTT_LISTEN_MS 250
/* A bus whose rate neither the transport nor the spec says (vcan): assumed, and said so. */
#define RTT_ASSUMED_BITRATE 1000000u

/* V3 §2.12, §2.14, §2.11 (V2 §3.31, §3.33, §3.29): status 1, status 2, multi-turn angle. */
static const uint8_t rtt_cmds[] = { 0x9A, 0x9C, 0x92 };
#define N_CLASSES (sizeof(rtt_cmds) / sizeof(rtt_cmds[0]))

/* One motor's round trips of one command. */
struct series {
	int64_t *ns; /* first-try round trips, sorted once measured */
	unsigned n;  /* answered */
	unsigned lost;
	bool pushed; /* the motor pushes this reply unasked: not measured */
	int64_t min_ns, median_ns, p99_ns, max_ns;
};

/* What one command class allows on this bus. */
struct verdict {
	bool measured;	       /* a motor answered it */
	int64_t p99_ns;	       /* the largest of the motors' */
	int64_t wire_ns;       /* 2N worst-case frames */
	int64_t cycle_ns;      /* the shortest cycle that holds it */
	unsigned rate_hz;      /* 1 s / cycle, rounded down */
	int64_t turnaround_ns; /* half duplex: what the planner's turnaround_us should be */
};

static int cmp_i64(const void *a, const void *b)
{
	int64_t x = *(const int64_t *)a, y = *(const int64_t *)b;

	return (x > y) - (x < y);
}

/* Nearest rank: the smallest value with at least q of the sample at or below it. */
static int64_t rank(const int64_t *v, unsigned n, double q)
{
	unsigned k = (unsigned)ceil(q * n);

	return v[k ? k - 1 : 0];
}

static void summarize(struct series *s)
{
	if (!s->n)
		return;
	qsort(s->ns, s->n, sizeof(s->ns[0]), cmp_i64);
	s->min_ns = s->ns[0];
	s->median_ns = rank(s->ns, s->n, 0.5);
	s->p99_ns = rank(s->ns, s->n, 0.99);
	s->max_ns = s->ns[s->n - 1];
}

/*
 * Listen RTT_LISTEN_MS before asking anything: s[c][i].pushed for each
 * measured command c that motor ids[i] sends unasked meanwhile.  Returns
 * 0 or -errno.
 */
static int listen_pushes(struct dev *d, const uint8_t *ids, unsigned n,
			 struct series s[][RMD_MAX_MOTORS])
{
	struct rmd_txn t[N_CLASSES][RMD_MAX_MOTORS];
	int64_t end = rmd_now_ns() + RTT_LISTEN_MS * RMD_NS_PER_MS;

	for (unsigned c = 0; c < N_CLASSES; c++)
		for (unsigned i = 0; i < n; i++) {
			struct rmd_msg m = { .cmd = rtt_cmds[c] };

			if (rmd_txn_prepare(&t[c][i], d->proto, ids[i], &m) < 0)
				t[c][i].reply_id = UINT32_MAX; /* matches nothing */
		}
	while (rmd_now_ns() < end) {
		struct rmd_bus_rx rx[16];
		int r = rmd_bus_recv(d->b, rx, 16, rmd_now_ns());

		if (r < 0)
			return r;
		for (int k = 0; k < r; k++)
			for (unsigned c = 0; c < N_CLASSES; c++)
				for (unsigned i = 0; i < n; i++)
					s[c][i].pushed |= rmd_txn_matches(&t[c][i], &rx[k].f);
		if (r < 16)
			rmdctl_sleep_until(rmd_now_ns() + RMD_NS_PER_MS);
	}
	return 0;
}

/*
 * One round: requests `cmd` to motors ids[0..n) (one each), all at once or,
 * on a half-duplex bus, one after the other; each first-try answer's round
 * trip goes into s[i].  Returns 0, or an exit status (reported).
 */
static int round_trip(struct dev *d, uint8_t cmd, const uint8_t *ids, unsigned n, bool half_duplex,
		      struct series *s)
{
	struct rmd_txn t[RMD_MAX_MOTORS];
	struct rmd_txn_opts o = d->txn;
	bool lost = false;
	unsigned step = half_duplex ? 1 : n;

	o.tries = 1;
	for (unsigned i = 0; i < n; i++) {
		struct rmd_msg m = { .cmd = cmd };
		int r = rmdctl_txn_prepare(&t[i], d, ids[i], &m);

		if (r)
			return r;
	}
	for (unsigned i = 0; i < n; i += step) {
		int r = rmdctl_txn_run(d, &t[i], step, &o);

		if (r)
			return r;
	}
	for (unsigned i = 0; i < n; i++) {
		/*
		 * A motor at angle 0 answers 0x92 with the request's own bytes
		 * (rmd/txn.h check_echo), which a lone first try cannot tell
		 * from a tripped motor's echo: either went through the motor,
		 * and its time is what is measured here.
		 */
		if (t[i].tries == 1 && t[i].heard && !t[i].no_reply) {
			s[i].ns[s[i].n++] = t[i].heard_ns - t[i].first_sent_ns;
		} else {
			s[i].lost++;
			lost = true;
		}
	}
	/* An answer still on its way must not pass for the next round's. */
	if (lost)
		rmdctl_sleep_until(rmd_now_ns() + o.timeout_ns);
	return 0;
}

/* round_trip() on the motors of ids[0..n) that do not push cmd's reply (s[i].pushed). */
static int round_trip_asked(struct dev *d, uint8_t cmd, const uint8_t *ids, unsigned n,
			    bool half_duplex, struct series *s)
{
	uint8_t asked[RMD_MAX_MOTORS];
	struct series sub[RMD_MAX_MOTORS];
	unsigned map[RMD_MAX_MOTORS], m = 0;
	int r;

	for (unsigned i = 0; i < n; i++)
		if (!s[i].pushed) {
			map[m] = i;
			asked[m] = ids[i];
			sub[m++] = s[i];
		}
	if (!m)
		return 0;
	r = round_trip(d, cmd, asked, m, half_duplex, sub);
	for (unsigned j = 0; j < m; j++)
		s[map[j]] = sub[j];
	return r;
}

/*
 * The shortest cycle in which every motor of s[0..n) gets one request of
 * the class and its reply, on a bus of the timing t (see the top of the
 * file).
 */
static void judge(const struct rmd_bus_timing *t, bool half_duplex, const struct series *s,
		  unsigned n, struct verdict *v)
{
	struct rmd_plan_bus b = { .bitrate = t->bitrate, .frame_bits = t->frame_bits };
	int64_t frame_ns = rmd_can_wire_ns(t->frame_bits, t->bitrate);
	unsigned answered = 0;

	memset(v, 0, sizeof(*v));
	for (unsigned i = 0; i < n; i++) {
		if (!s[i].n)
			continue;
		answered++;
		if (s[i].p99_ns > v->p99_ns)
			v->p99_ns = s[i].p99_ns;
	}
	if (!answered)
		return;
	v->measured = true;
	v->wire_ns = rmd_plan_cost_ns(&b, 2 * answered, answered);
	if (half_duplex) {
		/* the round trip holds the line: it is the request, the turnaround, the reply */
		b.turnaround_ns = v->p99_ns > 2 * frame_ns ? v->p99_ns - 2 * frame_ns : 0;
		v->turnaround_ns = b.turnaround_ns;
		v->cycle_ns = rmd_plan_cost_ns(&b, 2 * answered, answered);
	} else {
		/* pipelined: the wire carries them all; the slowest reply ends the cycle */
		v->cycle_ns = v->wire_ns > v->p99_ns ? v->wire_ns : v->p99_ns;
	}
	if (v->cycle_ns < 1)
		v->cycle_ns = 1;
	v->rate_hz = (unsigned)(RMD_NS_PER_S / v->cycle_ns);
}

static double ms(int64_t ns)
{
	return (double)ns / 1e6;
}

static void print_series(const struct dev *d, uint8_t id, uint8_t cmd, const struct series *s)
{
	const struct rmd_cmd_spec *spec = rmdctl_spec(d, cmd);

	if (d->json) {
		rmdctl_json_begin(d, id);
		printf(",\"cmd\":\"0x%02X\",\"name\":\"%s\",\"answered\":%u,\"lost\":%u,"
		       "\"pushed\":%s",
		       cmd, spec->name, s->n, s->lost, s->pushed ? "true" : "false");
		if (s->n)
			printf(",\"min_ms\":%.3f,\"median_ms\":%.3f,\"p99_ms\":%.3f,\"max_ms\":%.3f",
			       ms(s->min_ns), ms(s->median_ns), ms(s->p99_ns), ms(s->max_ns));
		else
			fputs(",\"min_ms\":null,\"median_ms\":null,\"p99_ms\":null,\"max_ms\":null",
			      stdout);
		fputs("}\n", stdout);
		return;
	}
	if (s->pushed) {
		printf("%3u  0x%02X %-21s %8s %9s %8s %8s %6s\n", id, cmd, spec->name, "pushed",
		       "-", "-", "-", "-");
		return;
	}
	if (!s->n) {
		printf("%3u  0x%02X %-21s %8s %9s %8s %8s %6u\n", id, cmd, spec->name, "-", "-",
		       "-", "-", s->lost);
		return;
	}
	printf("%3u  0x%02X %-21s %8.3f %9.3f %8.3f %8.3f %6u\n", id, cmd, spec->name,
	       ms(s->min_ns), ms(s->median_ns), ms(s->p99_ns), ms(s->max_ns), s->lost);
}

/*
 * The bus's rate and frame length, as the planner counts them
 * (rmd_bus_config_timing()), the rate as the open transport knows it
 * (struct rmd_bus_caps.bitrate).  Returns true when the rate is assumed:
 * neither the transport nor the spec says it (vcan).
 */
static bool bus_timing(const struct dev *d, struct rmd_bus_timing *t)
{
	struct rmd_bus_open_opts o = { .proto = d->proto, .baud = d->baud };
	struct rmd_config_bus cb;
	uint8_t ids[RMD_MAX_MOTORS];
	char err[128];
	bool assumed = false;

	if (rmd_bus_spec_parse(d->bus_spec, &o, &cb, ids, err, sizeof(err)) < 0 ||
	    rmd_bus_config_timing(&cb, t) < 0)
		memset(t, 0, sizeof(*t));
	if (!t->frame_bits)
		t->frame_bits = rmd_can_frame_bits_worst(RMD_FRAME_LEN);
	if (rmd_bus_caps(d->b)->bitrate)
		t->bitrate = rmd_bus_caps(d->b)->bitrate;
	if (!t->bitrate) {
		t->bitrate = RTT_ASSUMED_BITRATE;
		assumed = true;
	}
	if (!t->rate_unit)
		t->rate_unit = "bit/s";
	return assumed;
}

int rmdctl_run_rtt(struct dev *d, int argc, char **argv)
{
	uint8_t found[RMD_MAX_MOTORS];
	struct req st[RMD_MAX_MOTORS];
	struct series s[N_CLASSES][RMD_MAX_MOTORS];
	struct verdict v[N_CLASSES];
	struct rmd_bus_timing bt;
	unsigned n, rate = 0, worst = 0;
	bool half_duplex, assumed;
	int64_t *pool = NULL;
	int m, r = RMDCTL_EXIT_OK;

	if (!d->timeout_set)
		d->timeout_ms = RTT_TIMEOUT_MS;
	d->line_timeout = true; /* an RS485 line waits as long (rmdctl_open_bus()) */
	m = rmdctl_ids_probe(d, argc, argv, found, st, "");
	if (m < 0)
		return -m;
	n = (unsigned)m;
	half_duplex = rmd_bus_caps(d->b)->half_duplex;
	assumed = bus_timing(d, &bt);

	pool = calloc((size_t)N_CLASSES * n * d->count, sizeof(*pool));
	if (!pool) {
		tool_log(TOOL_LOG_ERR, "out of memory");
		rmdctl_close_bus(d);
		return RMDCTL_EXIT_DATA;
	}
	memset(s, 0, sizeof(s));
	for (unsigned c = 0; c < N_CLASSES; c++)
		for (unsigned i = 0; i < n; i++)
			s[c][i].ns = pool + ((size_t)c * n + i) * d->count;

	r = listen_pushes(d, found, n, s);
	if (r < 0) {
		tool_log(TOOL_LOG_ERR, "%s: %s", d->name, strerror(-r));
		r = RMDCTL_EXIT_DATA;
	}
	for (unsigned c = 0; c < N_CLASSES; c++)
		for (unsigned i = 0; i < n && rmdctl_spec(d, rtt_cmds[c]); i++)
			if (s[c][i].pushed)
				tool_log(
					TOOL_LOG_WARNING,
					"%s: motor %u pushes 0x%02X unasked (V4.2 §2.33 active reply, "
					"left on by another tool) and does not answer it: its 0x%02X "
					"round trip is not measured. rmdd's bring-up turns it off "
					"(0xB6)",
					d->name, found[i], rtt_cmds[c], rtt_cmds[c]);
	for (unsigned c = 0; c < N_CLASSES && !r; c++) {
		if (!rmdctl_spec(d, rtt_cmds[c]))
			continue;
		for (unsigned k = 0; k < d->count && !r; k++)
			r = round_trip_asked(d, rtt_cmds[c], found, n, half_duplex, s[c]);
		for (unsigned i = 0; i < n; i++)
			summarize(&s[c][i]);
		judge(&bt, half_duplex, s[c], n, &v[c]);
	}
	rmdctl_close_bus(d);
	if (r)
		goto out;

	if (!d->json)
		printf("%3s  %-26s %8s %9s %8s %8s %6s\n", "ID", "COMMAND", "MIN_MS", "MEDIAN_MS",
		       "P99_MS", "MAX_MS", "LOST");
	for (unsigned i = 0; i < n; i++)
		for (unsigned c = 0; c < N_CLASSES; c++)
			if (rmdctl_spec(d, rtt_cmds[c]))
				print_series(d, found[i], rtt_cmds[c], &s[c][i]);

	for (unsigned c = 0; c < N_CLASSES; c++) {
		if (!v[c].measured)
			continue;
		if (!rate || v[c].rate_hz < rate) {
			rate = v[c].rate_hz;
			worst = c;
		}
	}
	if (!rate) {
		tool_log(TOOL_LOG_ERR, "%s: no first-try answer in %u requests per motor", d->name,
			 d->count);
		r = RMDCTL_EXIT_DATA;
		goto out;
	}
	if (d->json) {
		fputs("{\"bus\":", stdout);
		rmdctl_json_str(d->name);
		printf(",\"motors\":%u,\"count\":%u,\"half_duplex\":%s,\"bitrate\":%" PRIu32
		       ",\"bitrate_assumed\":%s,\"frame_us\":%.1f,\"classes\":[",
		       n, d->count, half_duplex ? "true" : "false", bt.bitrate,
		       assumed ? "true" : "false",
		       (double)rmd_can_wire_ns(bt.frame_bits, bt.bitrate) / 1e3);
		for (unsigned c = 0, first = 1; c < N_CLASSES; c++) {
			if (!v[c].measured)
				continue;
			printf("%s{\"cmd\":\"0x%02X\",\"p99_ms\":%.3f,\"wire_ms\":%.3f,"
			       "\"cycle_ms\":%.3f,\"rate_hz\":%u}",
			       first ? "" : ",", rtt_cmds[c], ms(v[c].p99_ns), ms(v[c].wire_ns),
			       ms(v[c].cycle_ns), v[c].rate_hz);
			first = 0;
		}
		printf("],\"rate_hz\":%u", rate);
		if (half_duplex)
			printf(",\"turnaround_us\":%lld",
			       (long long)(v[worst].turnaround_ns / 1000));
		fputs("}\n", stdout);
		goto out;
	}
	printf("%s: %u motor%s, %u requests each per command, first tries only; %" PRIu32
	       " %s%s, %s\n",
	       d->name, n, n == 1 ? "" : "s", d->count, bt.bitrate, bt.rate_unit,
	       assumed ? " (assumed: the interface does not say)" : "",
	       half_duplex ? "half duplex (one request on the line at a time)" :
			     "requests and replies overlap");
	for (unsigned c = 0; c < N_CLASSES; c++) {
		if (!v[c].measured)
			continue;
		if (half_duplex)
			printf("0x%02X: %u requests in series, each its p99 round trip %.3f ms: "
			       "%.3f ms a cycle: up to %u Hz\n",
			       rtt_cmds[c], n, ms(v[c].p99_ns), ms(v[c].cycle_ns), v[c].rate_hz);
		else
			printf("0x%02X: %u frames on the wire %.3f ms, slowest reply p99 %.3f ms: "
			       "%.3f ms a cycle: up to %u Hz\n",
			       rtt_cmds[c], 2 * n, ms(v[c].wire_ns), ms(v[c].p99_ns),
			       ms(v[c].cycle_ns), v[c].rate_hz);
	}
	printf("%s: supported loop rate %u Hz (one request per motor per cycle, every reply "
	       "before the next cycle)\n",
	       d->name, rate);
	if (half_duplex)
		printf("%s: for rmdd.yaml, this bus's turnaround_us: %lld (p99 round trip less "
		       "the request and reply on the wire)\n",
		       d->name, (long long)(v[worst].turnaround_ns / 1000));
out:
	free(pool);
	return r;
}
