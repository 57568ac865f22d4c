// SPDX-License-Identifier: MIT
/*
 * rmdctl device commands and the transports under them:
 * - the sim bus backend through the ops table (rmd/bus_sim.h): a request
 *   is answered a turnaround plus wire time later, never at once;
 * - bus specs (rmd/bus_open.h) and request/reply transactions (rmd/txn.h);
 * - the built rmdctl ($RMDCTL, else $BUILD/rmdctl, else build/rmdctl) run
 *   as a real process against --bus sim:1-3.  Simulated motors live in the
 *   rmdctl process, so each run starts with fresh motors: a move is
 *   checked by the final angle the same run reports.
 */
#include <errno.h>
#include <math.h>
#include <setjmp.h>
#include <stdarg.h>
#include <stddef.h>
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/types.h>
#include <sys/wait.h>
#include <time.h>
#include <unistd.h>

#include <cmocka.h>

#include "rmd/time.h"
#include "rmd/bus.h"
#include "rmd/bus_open.h"
#include "rmd/bus_sim.h"
#include "rmd/codec.h"
#include "rmd/candump.h"
#include "rmd/sim_personality.h"
#include "rmd/sim_wire.h"
#include "rmd/txn.h"

#include "harness/json.h"
#include "harness/proc.h"
#include "harness/run_bound.h"
#include "harness/sleeper.h"
#include "tools/rmdctl/rmdctl.h"

#define MS 1000000LL
#define US 1000LL
/* Caller clock of the unit tests: any origin will do, the first call is the sim's epoch. */
#define T0 (5 * 1000000000LL)
/* A child that runs longer than this is killed: a hang fails the test, never stalls it. */
#define CHILD_LIMIT_S 20
#define REF_PERIOD_MS 1 /* the reference sleeper's period */
/* run_prog() looks for a child's exit every 5 ms: a run's took may include that much. */
#define EXIT_POLL_MS 5

static char rmdctl[4096];
/*
 * A reference sleeper at normal priority, as rmdctl runs (issue 10): the
 * time bounds below grow by the delay the machine imposed on it during the
 * run they judge (harness/run_bound.h), never by a fixed margin.
 */
static struct sleeper ref;

/* ---- sim bus through the ops table ------------------------------------------------------ */

static void open_sim(struct rmd_bus *bus, const uint8_t *ids, unsigned n, enum rmd_proto proto)
{
	struct rmd_bus_sim_motor m[RMD_MAX_MOTORS];
	struct rmd_bus_sim_opts o = { .motors = m, .n_motors = n };
	char err[256];
	int r;

	for (unsigned i = 0; i < n; i++)
		m[i] = (struct rmd_bus_sim_motor){ .id = ids[i], .proto = proto };
	r = rmd_bus_sim_open(bus, "sim0", &o, err, sizeof(err));
	if (r < 0)
		fail_msg("rmd_bus_sim_open: %d %s", r, err);
}

static struct rmd_frame request(enum rmd_proto proto, uint8_t id, uint8_t cmd)
{
	struct rmd_msg m = { .cmd = cmd };
	struct rmd_frame f;

	assert_int_equal(rmd_encode(proto, RMD_DIR_REQUEST, id, &m, &f), 0);
	return f;
}

static void test_sim_ops_basics(void **state)
{
	struct rmd_bus bus;
	const uint8_t ids[] = { 1, 2 };

	(void)state;
	open_sim(&bus, ids, 2, RMD_PROTO_V3);
	assert_string_equal(bus.ops->kind, "sim");
	assert_string_equal(bus.name, "sim0");
	assert_int_equal(rmd_bus_fd(&bus), -1);
	assert_int_equal(bus.state, RMD_BUS_ACTIVE);
	assert_non_null(rmd_bus_sim_get(&bus));
	assert_int_equal(rmd_bus_sim_get(&bus)->n_motors, 2);
	/* Before the first call there is no epoch. */
	assert_int_equal(rmd_bus_sim_time_ns(&bus, T0), 0);
	rmd_bus_close(&bus);
	assert_null(bus.ops);
	assert_null(bus.priv);
	rmd_bus_close(&bus); /* closed: no-op */
	rmd_bus_close(NULL);
}

/* A request is answered a turnaround (0.5 ms +- 0.1) plus two frames' wire time later. */
static void test_sim_ops_reply_timing(void **state)
{
	struct rmd_bus bus;
	struct rmd_bus_rx rx[8];
	const uint8_t ids[] = { 1, 2 };
	struct rmd_frame f = request(RMD_PROTO_V3, 2, 0x9A);
	struct rmd_msg msg;
	enum rmd_dir dir;
	int n;

	(void)state;
	open_sim(&bus, ids, 2, RMD_PROTO_V3);
	assert_int_equal(rmd_bus_send(&bus, &f, 1, T0), 1);
	assert_int_equal(rmd_bus_sim_time_ns(&bus, T0 + 7), 7);
	/* Not instantly, and not before the turnaround's lower bound. */
	assert_int_equal(rmd_bus_recv(&bus, rx, 8, T0), 0);
	assert_int_equal(rmd_bus_recv(&bus, rx, 8, T0 + 400 * US), 0);
	n = rmd_bus_recv(&bus, rx, 8, T0 + 2 * MS);
	assert_int_equal(n, 1);
	assert_int_equal(rx[0].f.can_id, RMD_CAN_V3_REPLY_BASE + 2);
	assert_int_equal(rx[0].f.data[0], 0x9A);
	/* Stamped in the caller's clock at the reply's end of frame. */
	if (rx[0].t_ns < T0 + 500 * US || rx[0].t_ns > T0 + 1000 * US)
		fail_msg("reply at +%lld us, expected 500..1000",
			 (long long)(rx[0].t_ns - T0) / US);
	assert_int_equal(rmd_decode(RMD_PROTO_V3, RMD_DIR_REPLY, &rx[0].f, &msg, &dir), 0);
	assert_int_equal(msg.cmd, 0x9A);
	assert_int_equal(msg.v[RMD_FLD_VOLTAGE], 480); /* 48 V at 0.1 V */
	assert_int_equal(bus.stats.tx_frames, 1);
	assert_int_equal(bus.stats.rx_frames, 1);
	/* Nothing more: a motor that is not there answers nothing. */
	f = request(RMD_PROTO_V3, 9, 0x9A);
	assert_int_equal(rmd_bus_send(&bus, &f, 1, T0 + 3 * MS), 1);
	assert_int_equal(rmd_bus_recv(&bus, rx, 8, T0 + 20 * MS), 0);
	rmd_bus_close(&bus);
}

/* Several requests on one wire: replies come one after another, each matched by id and command. */
static void test_sim_ops_pipelined(void **state)
{
	struct rmd_bus bus;
	struct rmd_bus_rx rx[16];
	const uint8_t ids[] = { 1, 2, 3 };
	struct rmd_frame f[6];
	bool seen[4][2] = { { false } };
	int n;

	(void)state;
	open_sim(&bus, ids, 3, RMD_PROTO_V3);
	for (unsigned i = 0; i < 3; i++) {
		f[2 * i] = request(RMD_PROTO_V3, ids[i], 0xB5);
		f[2 * i + 1] = request(RMD_PROTO_V3, ids[i], 0xB2);
	}
	assert_int_equal(rmd_bus_send(&bus, f, 6, T0), 6);
	n = rmd_bus_recv(&bus, rx, 16, T0 + 10 * MS);
	assert_int_equal(n, 6);
	for (int i = 0; i < n; i++) {
		unsigned id = rx[i].f.can_id - RMD_CAN_V3_REPLY_BASE;

		assert_in_range(id, 1, 3);
		assert_true(rx[i].f.data[0] == 0xB5 || rx[i].f.data[0] == 0xB2);
		seen[id][rx[i].f.data[0] == 0xB2] = true;
		if (i > 0)
			assert_true(rx[i].t_ns > rx[i - 1].t_ns); /* one wire: no two at once */
	}
	for (unsigned id = 1; id <= 3; id++)
		assert_true(seen[id][0] && seen[id][1]);
	rmd_bus_close(&bus);
}

/* A full TX queue takes what fits and counts the rest as busy, like SocketCAN. */
static void test_sim_ops_txqueue(void **state)
{
	struct rmd_bus_sim_motor m = { .id = 1, .proto = RMD_PROTO_V3 };
	struct rmd_bus_sim_opts o = { .motors = &m, .n_motors = 1, .txqueuelen = 2 };
	struct rmd_frame f[5];
	struct rmd_bus bus;
	char err[256];

	(void)state;
	assert_int_equal(rmd_bus_sim_open(&bus, "sim0", &o, err, sizeof(err)), 0);
	for (unsigned i = 0; i < 5; i++)
		f[i] = request(RMD_PROTO_V3, 1, 0x9A);
	assert_int_equal(rmd_bus_send(&bus, f, 5, T0), 2);
	assert_int_equal(bus.stats.tx_busy, 3);
	/* Still full at the same instant: nothing taken, not an error. */
	assert_int_equal(rmd_bus_send(&bus, f, 3, T0), 0);
	assert_int_equal(bus.stats.tx_busy, 6);
	rmd_bus_close(&bus);
}

static void test_sim_ops_bus_off(void **state)
{
	struct rmd_bus_sim_motor m = { .id = 1, .proto = RMD_PROTO_V3 };
	struct rmd_sim_fault fault = { .kind = RMD_SIM_FAULT_BUS_OFF,
				       .start_ns = 1 * MS,
				       .end_ns = 3 * MS };
	struct rmd_bus_sim_opts o = { .motors = &m, .n_motors = 1, .faults = &fault, .n_faults = 1 };
	struct rmd_frame f = request(RMD_PROTO_V3, 1, 0x9A);
	struct rmd_bus_rx rx[4];
	struct rmd_bus bus;
	char err[256];

	(void)state;
	assert_int_equal(rmd_bus_sim_open(&bus, "sim0", &o, err, sizeof(err)), 0);
	assert_int_equal(rmd_bus_recv(&bus, rx, 4, T0), 0); /* epoch */
	assert_int_equal(rmd_bus_send(&bus, &f, 1, T0 + 2 * MS), -ENETDOWN);
	assert_int_equal(bus.state, RMD_BUS_OFF);
	assert_int_equal(rmd_bus_recv(&bus, rx, 4, T0 + 4 * MS), 0);
	assert_int_equal(bus.state, RMD_BUS_ACTIVE);
	assert_int_equal(bus.stats.state_changes, 2);
	rmd_bus_close(&bus);
}

static void test_sim_open_errors(void **state)
{
	struct rmd_bus_sim_motor dup[2] = { { .id = 3, .proto = RMD_PROTO_V3 },
					    { .id = 3, .proto = RMD_PROTO_V2 } };
	struct rmd_bus_sim_motor bad = { .id = 33, .proto = RMD_PROTO_V3 };
	struct rmd_bus_sim_opts o = { .motors = dup, .n_motors = 2 };
	struct rmd_bus bus;
	char err[256];

	(void)state;
	assert_int_equal(rmd_bus_sim_open(&bus, "simx", &o, err, sizeof(err)), -EEXIST);
	assert_non_null(strstr(err, "simx"));
	assert_null(bus.ops);
	o.motors = &bad;
	o.n_motors = 1;
	assert_int_equal(rmd_bus_sim_open(&bus, "simx", &o, err, sizeof(err)), -EINVAL);
	assert_non_null(strstr(err, "33"));
	assert_int_equal(rmd_bus_sim_open(&bus, "simx", NULL, err, sizeof(err)), -EINVAL);
	o.motors = NULL;
	assert_int_equal(rmd_bus_sim_open(&bus, "simx", &o, err, sizeof(err)), -EINVAL);
	o.n_motors = 0;
	o.txqueuelen = 1000;
	assert_int_equal(rmd_bus_sim_open(&bus, "simx", &o, err, sizeof(err)), -EINVAL);
}

/* ---- bus specs -------------------------------------------------------------------------- */

static void test_parse_ids(void **state)
{
	uint8_t ids[RMD_MAX_MOTORS];

	(void)state;
	assert_int_equal(rmd_bus_open_parse_ids("1-3,7", ids), 4);
	assert_memory_equal(ids, ((uint8_t[]){ 1, 2, 3, 7 }), 4);
	assert_int_equal(rmd_bus_open_parse_ids("32,5", ids), 2);
	assert_int_equal(ids[0], 5);
	assert_int_equal(rmd_bus_open_parse_ids("1-32", ids), 32);
	assert_int_equal(rmd_bus_open_parse_ids("", ids), -EINVAL);
	assert_int_equal(rmd_bus_open_parse_ids("0", ids), -EINVAL);
	assert_int_equal(rmd_bus_open_parse_ids("33", ids), -EINVAL);
	assert_int_equal(rmd_bus_open_parse_ids("3-1", ids), -EINVAL);
	assert_int_equal(rmd_bus_open_parse_ids("1,1", ids), -EINVAL);
	assert_int_equal(rmd_bus_open_parse_ids("1-3,2", ids), -EINVAL);
	assert_int_equal(rmd_bus_open_parse_ids("1,", ids), -EINVAL);
	assert_int_equal(rmd_bus_open_parse_ids("1 2", ids), -EINVAL);
	assert_int_equal(rmd_bus_open_parse_ids("-1", ids), -EINVAL);
}

static void test_open_spec(void **state)
{
	struct rmd_bus_open_opts v2 = { .proto = RMD_PROTO_V2 };
	struct rmd_sim_wire *sim;
	struct rmd_bus bus;
	char err[256];

	(void)state;
	assert_true(rmd_bus_open_is_sim("sim"));
	assert_true(rmd_bus_open_is_sim("sim:1"));
	assert_false(rmd_bus_open_is_sim("simcan0"));
	assert_false(rmd_bus_open_is_sim("can0"));

	assert_int_equal(rmd_bus_open_spec(&bus, "sim", NULL, err, sizeof(err)), 0);
	assert_string_equal(bus.ops->kind, "sim");
	sim = rmd_bus_sim_get(&bus);
	assert_non_null(sim);
	assert_int_equal(sim->n_motors, RMD_BUS_OPEN_SIM_MOTORS);
	for (uint8_t id = 1; id <= RMD_BUS_OPEN_SIM_MOTORS; id++)
		assert_non_null(rmd_sim_wire_motor(sim, id));
	rmd_bus_close(&bus);

	assert_int_equal(rmd_bus_open_spec(&bus, "sim:1-3,7", &v2, err, sizeof(err)), 0);
	assert_string_equal(bus.name, "sim:1-3,7");
	sim = rmd_bus_sim_get(&bus);
	assert_int_equal(sim->n_motors, 4);
	assert_non_null(rmd_sim_wire_motor(sim, 7));
	assert_null(rmd_sim_wire_motor(sim, 4));
	assert_int_equal(rmd_sim_wire_motor(sim, 7)->p.proto, RMD_PROTO_V2);
	rmd_bus_close(&bus);

	assert_int_equal(rmd_bus_open_spec(&bus, "sim:", NULL, err, sizeof(err)), -EINVAL);
	assert_int_equal(rmd_bus_open_spec(&bus, "sim:0-3", NULL, err, sizeof(err)), -EINVAL);
	assert_non_null(strstr(err, "sim:0-3"));
	assert_int_equal(rmd_bus_open_spec(&bus, "", NULL, err, sizeof(err)), -EINVAL);
	/* A path is RS485; V2 has none. */
	assert_int_equal(rmd_bus_open_spec(&bus, "/dev/ttyRMDnone", &v2, err, sizeof(err)),
			 -EINVAL);
	assert_non_null(strstr(err, "V2"));
	assert_true(rmd_bus_open_spec(&bus, "/dev/ttyRMDnone", NULL, err, sizeof(err)) < 0);
	assert_non_null(strstr(err, "/dev/ttyRMDnone"));
	/* Anything else is SocketCAN: this kernel may lack it, the name is missing anyway. */
	assert_true(rmd_bus_open_spec(&bus, "rmdnone0", NULL, err, sizeof(err)) < 0);
	assert_non_null(strstr(err, "rmdnone0"));
	assert_null(bus.ops);
}

/* ---- transactions over the sim bus ------------------------------------------------------ */

/* The batch of test_txn_sim(), one silent of four: a run_bound_fn. */
struct txn_batch {
	struct rmd_bus *bus;
	struct rmd_txn *t;
	struct rmd_txn_opts o;
	int done; /* rmd_txn_run()'s result */
	int64_t took_ns;
};

static int64_t txn_batch_run(void *ctx, int64_t *startup_ns, int64_t *design_ns)
{
	struct txn_batch *b = ctx;
	int64_t start = rmd_now_ns();

	b->done = rmd_txn_run(b->bus, b->t, 4, &b->o);
	b->took_ns = rmd_now_ns() - start;
	*startup_ns = 0; /* no process to start */
	(void)design_ns;
	return b->took_ns;
}

static void test_txn_sim(void **state)
{
	const uint8_t ids[] = { 1, 2, 3 };
	struct rmd_msg m9a = { .cmd = 0x9A }, mb5 = { .cmd = 0xB5 };
	struct rmd_txn t[4];
	struct rmd_bus bus;
	struct txn_batch b = { .bus = &bus, .t = t, .o = { .timeout_ns = 5 * MS, .tries = 3 } };
	int64_t took;

	(void)state;
	open_sim(&bus, ids, 3, RMD_PROTO_V3);
	assert_int_equal(rmd_txn_prepare(&t[0], RMD_PROTO_V3, 3, &m9a), 0);
	assert_int_equal(rmd_txn_prepare(&t[1], RMD_PROTO_V3, 9, &m9a), 0);
	assert_int_equal(rmd_txn_prepare(&t[2], RMD_PROTO_V3, 1, &mb5), 0);
	assert_int_equal(rmd_txn_prepare(&t[3], RMD_PROTO_V3, 2, &m9a), 0);
	assert_int_equal(t[0].reply_id, RMD_CAN_V3_REPLY_BASE + 3);
	assert_int_equal(t[0].reply_cmd, 0x9A);
	/*
	 * A silent motor costs about tries * timeout, never a hang: at most
	 * the batch's design bound plus what the machine held this thread off
	 * at the start of each try (one wait a try).
	 */
	run_bound_judge(&ref, "rmd_txn_run, one of 4 silent", txn_batch_run, &b,
			txn_silent_ns(4, b.o.timeout_ns, b.o.tries, RMD_TXN_CAN_SPACING_NS),
			b.o.tries);
	took = b.took_ns;
	assert_int_equal(b.done, 3);
	assert_true(t[0].done && t[2].done && t[3].done);
	assert_false(t[1].done);
	assert_int_equal(t[0].tries, 1);
	assert_int_equal(t[1].tries, 3);
	/* Each answer is its own motor's, for its own command. */
	assert_int_equal(t[0].rep.f.can_id, RMD_CAN_V3_REPLY_BASE + 3);
	assert_int_equal(t[2].rep.f.can_id, RMD_CAN_V3_REPLY_BASE + 1);
	assert_int_equal(t[2].rep.f.data[0], 0xB5);
	assert_int_equal(t[3].rep.f.can_id, RMD_CAN_V3_REPLY_BASE + 2);
	/* ... and at least each try's timeout. */
	if (took < 15 * MS)
		fail_msg("took %.1f ms, less than 3 tries of 5 ms", (double)took / MS);
	/* A reset answers nothing: done once sent. */
	{
		struct rmd_msg m76 = { .cmd = 0x76 };

		assert_int_equal(rmd_txn_prepare(&t[0], RMD_PROTO_V3, 1, &m76), 0);
		assert_true(t[0].no_reply);
		assert_int_equal(rmd_txn_run(&bus, t, 1, &b.o), 1);
	}
	rmd_bus_close(&bus);
}

static void test_txn_matching(void **state)
{
	struct rmd_msg m = { .cmd = 0x79 };
	struct rmd_frame rx = { .can_id = 0x243, .len = 8, .data = { 0x9C } };
	struct rmd_txn t;

	(void)state;
	assert_int_equal(rmd_txn_prepare(&t, RMD_PROTO_V3, 3, &(struct rmd_msg){ .cmd = 0x9A }), 0);
	assert_false(rmd_txn_matches(&t, &rx)); /* same motor, other command */
	rx.data[0] = 0x9A;
	assert_true(rmd_txn_matches(&t, &rx));
	rx.can_id = 0x242;
	assert_false(rmd_txn_matches(&t, &rx)); /* other motor */
	rx.can_id = 0x143;
	assert_false(rmd_txn_matches(&t, &rx)); /* a request, not a V3 reply */
	/* V2 answers on 0x140 + ID; V3 0x79 on 0x300. */
	assert_int_equal(rmd_txn_prepare(&t, RMD_PROTO_V2, 3, &(struct rmd_msg){ .cmd = 0x9A }), 0);
	assert_int_equal(t.reply_id, 0x143);
	rmd_msg_set(&m, RMD_FLD_READ_FLAG, 1);
	assert_int_equal(rmd_txn_prepare(&t, RMD_PROTO_V3, 3, &m), 0);
	assert_int_equal(t.req.can_id, RMD_CAN_SET_ID);
	assert_int_equal(t.reply_id, RMD_CAN_SET_ID);
	/* A broadcast is not a transaction. */
	assert_int_equal(rmd_txn_prepare(&t, RMD_PROTO_V3, 0, &(struct rmd_msg){ .cmd = 0x9A }),
			 -EINVAL);
}

/* ---- rmdctl as a process ---------------------------------------------------------------- */

/*
 * rmdctl runs with stdin a file (never a terminal) holding a "y" that must
 * not count as confirmation, and no RMDCTL_BUS from the caller.
 */
static const struct run_opts dev_opts = { .input = "y\n",
					  .input_len = 2,
					  .unset_env = "RMDCTL_BUS",
					  .limit_ms = CHILD_LIMIT_S * 1000 };

/* Run rmdctl with args (NULL-terminated). */
static void run_argv(struct run *r, const char *const *args)
{
	run_prog(r, rmdctl, args, &dev_opts);
}

#define RUN(r, ...) run_argv((r), (const char *const[]){ __VA_ARGS__, NULL })

/*
 * The took of a trivial rmdctl run on this machine now: a process's start
 * and end, the bus opened and closed, one silent try of 1 ms.
 */
static int64_t trivial_took_ns(void)
{
	struct run t;
	int64_t took;

	RUN(&t, "status", "9", "--bus", "sim:1-3", "--timeout", "1", "--tries", "1");
	assert_status(&t, 1, "a trivial status 9");
	took = t.took_ns;
	run_free(&t);
	return took;
}

/* One timed rmdctl run: a run_bound_fn. */
struct timed {
	struct run *r;
	const char *const *args;
};

/* Run t's args, as run_argv(), beside a trivial run before and one after (the longer). */
static int64_t timed_run(void *ctx, int64_t *startup_ns, int64_t *design_ns)
{
	struct timed *t = ctx;
	int64_t after_ns;

	(void)design_ns;
	*startup_ns = trivial_took_ns();
	run_free(t->r);
	run_argv(t->r, t->args);
	after_ns = trivial_took_ns();
	if (after_ns > *startup_ns)
		*startup_ns = after_ns;
	return t->r->took_ns;
}

/*
 * Run rmdctl with args, as run_argv(), and fail unless it ended within its
 * bound (harness/run_bound.h: run_bound_judge()): design_ns, what it takes
 * on an idle machine (and the test's look for its exit), plus what the
 * machine measurably added -- a trivial run's took and, for its `waits`
 * waits in sequence, the reference sleeper's delays during the run.
 */
static void run_timed(struct run *r, const char *what, const char *const *args, int64_t design_ns,
		      unsigned waits)
{
	struct timed t = { .r = r, .args = args };

	*r = (struct run){ 0 };
	run_bound_judge(&ref, what, timed_run, &t, design_ns + EXIT_POLL_MS * MS, waits);
}

/* A table of rmdctl runs, each run as run_argv() runs one. */
static void run_cases_dev(const struct run_case *c, size_t n)
{
	run_cases(rmdctl, c, n, &dev_opts);
}

/* One run and its checks: CHECK_RUN(.args = { ... }, .status = 1, .err_has = { ... }). */
#define CHECK_RUN(...) run_cases_dev(&(struct run_case){ __VA_ARGS__ }, 1)

/* rmdctl's default per-try timeout and tries (rmd/txn.h), on the sim bus's spacing. */
static int64_t silent_ns(unsigned n)
{
	return txn_silent_ns(n, RMD_TXN_TIMEOUT_NS, RMD_TXN_TRIES, RMD_TXN_CAN_SPACING_NS);
}

/* Without --timeout the first 0x9A of a run waits this long for a silent motor (rmdctl.h). */
#define WAIT_PROBE_NS ((int64_t)RMDCTL_WAIT_PROBE_MS * MS)

/* A probe of n ids without --timeout, all silent: the measuring try, then the others. */
static int64_t silent_probe_ns(unsigned n)
{
	return WAIT_PROBE_NS +
	       txn_silent_ns(n, RMD_TXN_TIMEOUT_NS, RMD_TXN_TRIES - 1, RMD_TXN_CAN_SPACING_NS);
}

static void test_scan(void **state)
{
	struct run r;
	char want[128];

	(void)state;
	/*
	 * Pipelined probes of 32 ids (29 silent): the try that measures the
	 * wait, then two more; then 0xB5 and 0xB2 of the three that answered
	 * (3 tries), each try a wait; one more for this test to see rmdctl's
	 * end, one for the lone 0x9A that may follow the measuring try.
	 */
	run_timed(&r, "scan", (const char *const[]){ "scan", "--bus", "sim:1-3", "--json", NULL },
		  silent_probe_ns(RMD_MAX_MOTORS) + silent_ns(6), 2 * RMD_TXN_TRIES + 2);
	assert_status(&r, 0, "scan");
	assert_int_equal(count_lines(r.out), 3);
	for (int id = 1; id <= 3; id++) {
		snprintf(want, sizeof(want),
			 "\"motor_id\":%d,\"protocol\":\"v3\",\"dialect\":\"v3\","
			 "\"dialect_certain\":true,\"model\":\"X8S2V10\","
			 "\"version_date\":20220206,",
			 id);
		assert_has(r.out, want, "scan --json");
	}
	assert_lacks(r.out, "\"motor_id\":4,", "scan --json");
	assert_has(r.out, "\"bus\":\"sim:1-3\"", "scan --json");
	assert_has(r.out, "\"errors\":[]", "scan --json");
	run_free(&r);

	CHECK_RUN(.args = { "scan", "--bus", "sim:1-3" },
		  .out_has = { "X8S2V10", "20220206", "3 motors answered" });
	/* Nothing there: exit 1 with the bus named. */
	CHECK_RUN(.args = { "scan", "10-12", "--bus", "sim:1-3" }, .status = 1,
		  .err_has = { "sim:1-3: no motor answered" });
}

static void test_status(void **state)
{
	struct run r;

	(void)state;
	RUN(&r, "status", "2", "--bus", "sim:1-3", "--json");
	assert_status(&r, 0, "status 2");
	assert_int_equal((int)json_num(r.out, "temperature_c"), 25);
	assert_true(fabs(json_num(r.out, "voltage_v") - 48) < 0.5);
	ASSERT_HAS_ALL(r.out, "status 2", "\"motor_id\":2,", "\"error_code\":0,\"errors\":[]",
		       "\"brake_released\":false", "\"angle_deg\":0",
		       "\"speed_dps\":", "\"current_a\":");
	run_free(&r);

	CHECK_RUN(.args = { "status", "1", "--bus", "sim:1-3" },
		  .out_has = { "voltage", "errors           none" });
}

/* A missing motor: an error naming bus, motor, command and timeout, in bounded time. */
static void test_status_missing(void **state)
{
	struct run r;

	(void)state;
	/*
	 * The 0x9A that measures the wait (100 ms), then one batch of 3
	 * requests (0x9A, 0x92, 0x9C), 3 tries of 5 ms; one wait each, one more.
	 */
	run_timed(&r, "status 9", (const char *const[]){ "status", "9", "--bus", "sim:1-3", NULL },
		  WAIT_PROBE_NS + silent_ns(3), RMD_TXN_TRIES + 2);
	assert_status(&r, 1, "status 9");
	assert_has(r.err,
		   "sim:1-3: motor 9 did not answer 0x9A within 5 ms (3 tries; nor 0x9A in 100 ms "
		   "before)",
		   "status 9");
	assert_string_equal(r.out, "");
	run_free(&r);

	CHECK_RUN(.args = { "status", "9", "--bus", "sim:1-3", "--timeout", "2", "--tries", "1" },
		  .status = 1, .err_has = { "motor 9 did not answer 0x9A within 2 ms (1 try)" });
}

/* How many times needle is in hay. */
static unsigned count_of(const char *hay, const char *needle)
{
	unsigned n = 0;

	for (const char *p = strstr(hay, needle); p; p = strstr(p + 1, needle))
		n++;
	return n;
}

/*
 * Issue 32 point 10: motors behind a slow USB adapter (answers held by a
 * 16 ms latency timer, or 8 or 48 ms late) are found by scan, and answer a
 * device command, without --timeout: the wait is measured first and said
 * on stderr, in bounded time.  A write goes out once: every try of 0xB3 is
 * a ROM write (the wire, --trace, says how many went out).
 */
static void test_slow_adapter(void **state)
{
	static const char *const slow[] = { "adapter_latency_timer_us=16000",
					    "adapter_delay_us=8000", "adapter_delay_us=48000" };
	/*
	 * The measuring 0x9A (29 ids silent), the lone one to the slowest, two
	 * more tries of the silent ids and the 0xB5/0xB2 batch, each try at
	 * most the longest wait; one wait each, one more for the test.
	 */
	int64_t design = 2 * WAIT_PROBE_NS +
			 txn_silent_ns(RMD_MAX_MOTORS, WAIT_PROBE_NS, RMD_TXN_TRIES - 1,
				       RMD_TXN_CAN_SPACING_NS) +
			 txn_silent_ns(6, WAIT_PROBE_NS, RMD_TXN_TRIES, RMD_TXN_CAN_SPACING_NS);
	struct run r;

	(void)state;
	for (size_t i = 0; i < sizeof(slow) / sizeof(slow[0]); i++) {
		run_timed(&r, slow[i],
			  (const char *const[]){ "scan", "--bus", "sim:1-3", "--json", "--sim",
						 slow[i], NULL },
			  design, 2 * RMD_TXN_TRIES + 3);
		assert_status(&r, 0, slow[i]);
		if (count_lines(r.out) != 3)
			fail_msg("%s: scan found %zu motors, not 3:\n%s%s", slow[i],
				 count_lines(r.out), r.out, r.err);
		ASSERT_HAS_ALL(r.err, slow[i], "answered 0x9A after ",
			       " ms per try (--timeout sets it)");
		run_free(&r);
	}
	RUN(&r, "set-timeout", "2", "500", "--yes", "--bus", "sim:1-3", "--trace", "--sim",
	    "adapter_delay_us=30000");
	assert_status(&r, 0, "set-timeout, 30 ms adapter");
	assert_has(r.out, "echo verified", "set-timeout, 30 ms adapter");
	if (count_of(r.err, " sim:1-3 142#B3000000F4010000\n# TX ") != 1)
		fail_msg("0xB3 went out %u times, not once:\n%s",
			 count_of(r.err, " sim:1-3 142#B3000000F4010000\n# TX "), r.err);
	run_free(&r);
	CHECK_RUN(.args = { "status", "2", "--bus", "sim:1-3", "--json", "--sim",
			    "adapter_latency_timer_us=16000" },
		  .out_has = { "\"motor_id\":2," });
	/* the old fixed wait: nothing found behind the 48 ms adapter */
	CHECK_RUN(.args = { "scan", "--bus", "sim:1-3", "--timeout", "5", "--sim",
			    "adapter_delay_us=48000" },
		  .status = 1,
		  .err_has = { "no motor answered 0x9A (32 ids probed, V3, 5 ms x 3" });
	/* a fast bus: no wait widened, nothing said */
	CHECK_RUN(.args = { "scan", "--bus", "sim:1-3" }, .err_lacks = "ms per try");
}

/*
 * Issue 32 point 16: firmware that echoes 0x20 index 5 from the NEW id
 * (2025070202) gets the write once, not once per try: each is a flash
 * write.  The wire (--trace) counts the writes.
 */
static void test_set_id_writes_once(void **state)
{
	static const char write_tx[] = " sim:1-3 142#2005000009000000\n# TX ";
	struct run r;

	(void)state;
	RUN(&r, "set-id", "2", "9", "--yes", "--bus", "sim:1-3", "--protocol", "v4", "--trace");
	assert_status(&r, 0, "set-id v4");
	assert_has(r.out, "motor 2 is now motor 9", "set-id v4");
	assert_has(r.err, " sim:1-3 249#2005000009000000\n# RX ", "set-id v4: the new id's echo");
	if (count_of(r.err, write_tx) != 1)
		fail_msg("0x20 index 5 went out %u times, not once:\n%s", count_of(r.err, write_tx),
			 r.err);
	run_free(&r);
}

/*
 * Issue 32 point 2: 0x20 index 5 takes effect at the reset (0x76), and the
 * motor boots for 1.1 s (1.12 s was measured) before it answers: set-id
 * waits for the boot, then judges by what the motor says -- the new id's
 * runtime (0xB1) restarted, the old id silent -- and says so.  On the
 * wire: one write, one reset, then the new id's 0xB1 answer.
 */
static void test_set_id_reboot(void **state)
{
	struct run r;
	const char *reset, *runtime;

	(void)state;
	RUN(&r, "set-id", "2", "9", "--yes", "--bus", "sim:1-3", "--protocol", "v4", "--trace",
	    "--sim", "boot_ms=1100");
	assert_status(&r, 0, "set-id across a 1.1 s boot");
	ASSERT_HAS_ALL(r.out, "set-id across a 1.1 s boot", "motor 2 is now motor 9 (ROM)",
		       "after the reset id 9 answers", "its runtime restarted",
		       "id 2 no longer does");
	reset = strstr(r.err, " sim:1-3 142#7600000000000000\n# TX ");
	runtime = strstr(r.err, " sim:1-3 249#B1");
	if (!reset || !runtime || runtime < reset ||
	    count_of(r.err, " sim:1-3 142#7600000000000000\n# TX ") != 1)
		fail_msg("expected one 0x76 to id 2, then 0xB1 answered from id 9:\n%s", r.err);
	run_free(&r);
}

/*
 * Issue 32 points 1 and 2 on the simulator's personalities (rmd/sim_personality.h):
 * - an X4-64 of 2025070202 driven with the default --protocol v3: set-id
 *   asks its 0xB2, renumbers it by 0x20 index 5 and 0x76 (never 0x79,
 *   which it answers with a 0xB2 frame), waits out its 1.12 s boot and
 *   says the new id answers and the old does not;
 * - a 0x79 answered by a 0xB2 frame is no ID answer: said, exit 1, and
 *   0x79 went out once;
 * - an X4-36 (echo from the new id, the old id's requests answered from
 *   it until the reset) is renumbered; an id another motor answers on is
 *   refused before anything is written.
 */
static void test_set_id_personalities(void **state)
{
	struct run r;

	(void)state;
	RUN(&r, "set-id", "1", "2", "--yes", "--bus", "sim:1", "--trace", "--sim",
	    "personality=x4-64-2025070202");
	assert_status(&r, 0, "set-id on an X4-64 2025070202");
	ASSERT_HAS_ALL(r.err, "set-id X4-64", "firmware (date 2025070202) is V4",
		       " sim:1 141#2005000002000000\n# TX ", " sim:1 242#2005000002000000\n# RX ",
		       " sim:1 141#7600000000000000\n# TX ");
	assert_lacks(r.err, "#79", "set-id X4-64: no 0x79");
	ASSERT_HAS_ALL(r.out, "set-id X4-64", "motor 1 is now motor 2 (ROM)",
		       "its runtime restarted", "id 1 no longer does");
	if (count_of(r.err, " sim:1 141#2005000002000000\n# TX ") != 1)
		fail_msg("0x20 index 5 went out more than once:\n%s", r.err);
	run_free(&r);

	RUN(&r, "set-id", "2", "9", "--yes", "--bus", "sim:2", "--trace", "--sim",
	    "answers_79_as_b2=yes");
	assert_status(&r, 1, "set-id, 0x79 answered by 0xB2");
	ASSERT_HAS_ALL(r.err, "set-id, 0x79 answered by 0xB2", "motor 2 answered 0x79 with 242#B2",
		       "it takes no 0x79, the id did not change");
	assert_lacks(r.out, "is now motor", "set-id, 0x79 answered by 0xB2");
	if (count_of(r.err, " sim:2 300#7900000000000009\n# TX ") != 1)
		fail_msg("0x79 went out %u times, not once:\n%s",
			 count_of(r.err, " sim:2 300#7900000000000009\n# TX "), r.err);
	run_free(&r);

	CHECK_RUN(.args = { "set-id", "2", "1", "--yes", "--bus", "sim:2", "--protocol", "v4",
			    "--sim", "personality=x4-36-2025070202" },
		  .out_has = { "motor 2 is now motor 1 (ROM): after the reset id 1 answers",
			       "id 2 no longer does" });
	CHECK_RUN(.args = { "set-id", "1", "2", "--yes", "--bus", "sim:1-2", "--protocol", "v4",
			    "--trace", "--sim", "personality=x4-36-2025070202" },
		  .status = 1, .err_has = { "id 2 is taken" }, .err_lacks = "#2005");
}

/* ---- characterize (issue 32 point 12) --------------------------------------------------- */

/* The recorded motor: its own 0x9A distribution, another for the rest, quirks to find. */
static const char recorded[] = "format = rmd-personality 1\n"
			       "name = test-x4-64\n"
			       "model = X4-64\n"
			       "version_date = 2025070202\n"
			       "dialect = v4\n"
			       "boot_ms = 300\n"
			       "answers_79_as_b2 = yes\n"
			       "ignores = 0x94\n"
			       "turnaround 0x9A = 300 350 400 600 900 1000\n"
			       "turnaround * = 500 600 800 1200 1500 1600\n";

/* A personality file's record; fails the test on a parse error. */
static void load_personality(const char *path, struct rmd_personality *p)
{
	char text[RMD_PERSONALITY_FILE_MAX], err[256];
	FILE *f = fopen(path, "r");
	size_t n;

	if (!f)
		fail_msg("%s: %s", path, strerror(errno));
	n = fread(text, 1, sizeof(text), f);
	fclose(f);
	if (rmd_personality_parse(text, n, path, p, err, sizeof(err)) < 0)
		fail_msg("%s", err);
}

/* Median and p90 of line got within 10 % of want's. */
static void assert_close(const char *what, unsigned cmd,
			 const struct rmd_personality_turnaround *got,
			 const struct rmd_personality_turnaround *want)
{
	static const unsigned qk[] = { 2, 3 }; /* p50, p90 (rmd_personality_quantiles) */

	if (!got || !want)
		fail_msg("%s: 0x%02X: no turnaround line", what, cmd);
	for (size_t k = 0; k < sizeof(qk) / sizeof(qk[0]); k++) {
		double g = got->q_us[qk[k]], w = want->q_us[qk[k]];

		if (fabs(g - w) > 0.1 * w)
			fail_msg("%s: 0x%02X: p%.0f %g us, expected %g us +- 10 %%", what, cmd,
				 rmd_personality_quantiles[qk[k]] * 100, g, w);
	}
}

/* The same answers: model, date, dialect, the quirk, what it ignores, its boot (10 %). */
static void assert_same_motor(const char *what, const struct rmd_personality *got,
			      const struct rmd_personality *want)
{
	assert_string_equal(got->model, want->model);
	assert_int_equal(got->version_date, want->version_date);
	assert_int_equal(got->proto, want->proto);
	assert_true(rmd_personality_gives(got, RMD_PERSONALITY_ANSWERS_79_AS_B2));
	assert_true(got->flags & (1u << RMD_PERSONALITY_ANSWERS_79_AS_B2));
	assert_memory_equal(got->ignores, want->ignores, sizeof(got->ignores));
	if (fabs((double)got->boot_ms - want->boot_ms) > 0.1 * want->boot_ms + 10)
		fail_msg("%s: boot_ms %u, expected %u", what, got->boot_ms, want->boot_ms);
}

/* Every read the dialect has, judged against the turnaround lines of want. */
static void assert_turnarounds(const char *what, const struct rmd_personality *got,
			       const struct rmd_personality *want)
{
	unsigned n = 0;

	for (unsigned i = 0; i < got->n_turnaround; i++) {
		unsigned cmd = got->turnaround[i].cmd;

		if (cmd == RMD_PERSONALITY_CMD_ANY)
			continue;
		assert_close(what, cmd, &got->turnaround[i],
			     rmd_personality_turnaround_for(want, cmd));
		n++;
	}
	if (n < 10)
		fail_msg("%s: %u commands measured, expected every read of V4", what, n);
}

/*
 * characterize against a simulated motor with a recorded personality
 * writes a file from which the simulator gives the same answers and a
 * turnaround distribution within 10 % (median, p90) -- of the recording
 * and of the file itself, characterized again; its log is `candump -l`
 * that `rmdctl decode` reads; nothing moves without --move.
 */
static void test_characterize(void **state)
{
	char dir[] = "/tmp/rmdctl-char-XXXXXX", in[64], f1[64], f2[64], arg[128], path[96];
	struct rmd_personality want, p1, p2;
	struct run r;
	FILE *f;

	(void)state;
	assert_non_null(mkdtemp(dir));
	snprintf(in, sizeof(in), "%s/in.personality", dir);
	snprintf(f1, sizeof(f1), "%s/f1", dir);
	snprintf(f2, sizeof(f2), "%s/f2", dir);
	f = fopen(in, "w");
	assert_non_null(f);
	fputs(recorded, f);
	fclose(f);
	load_personality(in, &want);

	snprintf(arg, sizeof(arg), "personality=%s", in);
	RUN(&r, "characterize", "1", "--yes", "--bus", "sim:1", "--sim", arg, "--out", f1);
	assert_status(&r, 0, "characterize");
	ASSERT_HAS_ALL(r.out, "characterize", "model X4-64, firmware 2025070202, V4",
		       "answers 0x79 with a 0xB2 frame", "0x94 never answered", "wrote ");
	run_free(&r);
	snprintf(path, sizeof(path), "%s.personality", f1);
	load_personality(path, &p1);
	assert_same_motor("recorded", &p1, &want);
	assert_turnarounds("recorded", &p1, &want);

	/* the file replayed: the same motor again */
	snprintf(arg, sizeof(arg), "personality=%s", path);
	RUN(&r, "characterize", "1", "--yes", "--bus", "sim:1", "--sim", arg, "--out", f2);
	assert_status(&r, 0, "characterize the replay");
	run_free(&r);
	snprintf(path, sizeof(path), "%s.personality", f2);
	load_personality(path, &p2);
	assert_same_motor("replayed", &p2, &p1);
	assert_turnarounds("replayed", &p2, &p1);

	/* the log: candump -l lines, each request of a read there, no motion */
	{
		char line[256];
		unsigned n = 0, a4 = 0, b5 = 0;

		snprintf(path, sizeof(path), "%s.log", f1);
		f = fopen(path, "r");
		assert_non_null(f);
		while (fgets(line, sizeof(line), f)) {
			struct rmd_candump_line l;

			if (rmd_candump_parse(line, &l) < 0)
				fail_msg("%s: not candump -l: %s", path, line);
			n++;
			a4 += strstr(line, " sim:1 141#A4") != NULL;
			b5 += strstr(line, " sim:1 141#B5") != NULL;
		}
		fclose(f);
		if (n < 1000 || a4 || !b5)
			fail_msg("%s: %u lines, %u 0xA4, %u 0xB5", path, n, a4, b5);
	}
	CHECK_RUN(.args = { "decode", path }, .out_has = { "read_model" });
	/* --move: bounded, and then it moves and comes back */
	CHECK_RUN(.args = { "characterize", "1", "--yes", "--bus", "sim:1", "--move", "20", "--out",
			    f2 },
		  .status = 2, .err_has = { "at most 10 deg" });
	CHECK_RUN(.args = { "characterize", "1", "--yes", "--bus", "sim:1", "--move", "5",
			    "--speed", "30", "--out", f2 },
		  .status = 2, .err_has = { "1..10 dps" });
	CHECK_RUN(.args = { "characterize", "1", "--yes", "--bus", "sim:1", "--move", "3",
			    "--count", "5", "--out", f2 },
		  .out_has = { "at 3.", "at 0.", "wrote " });
	/* docs/characterize.md's example: a built-in personality */
	CHECK_RUN(.args = { "characterize", "1", "--bus", "sim:1", "--sim",
			    "personality=x4-64-2025070202", "--yes", "--count", "5", "--out", f2 },
		  .out_has = { "model X4-64", "reset (0x76), answering again after 11" });
	CHECK_RUN(.args = { "characterize", "1", "--bus", "sim:1", "--out", f2 }, .status = 2,
		  .err_has = { "--yes" });
	snprintf(path, sizeof(path), "rm -rf %s", dir);
	assert_int_equal(system(path), 0);
}

static void test_move(void **state)
{
	struct run r;
	double angle;

	(void)state;
	RUN(&r, "move", "2", "10", "--yes", "--bus", "sim:1-3", "--json");
	assert_status(&r, 0, "move 2 10");
	assert_has(r.out, "\"motor_id\":2,", "move");
	assert_has(r.out, "\"arrived\":true", "move");
	angle = json_num(r.out, "angle_deg");
	if (fabs(angle - 10) > 0.2)
		fail_msg("move ended at %g deg", angle);
	run_free(&r);

	/* Negative angles are arguments, not options; text output reports the final angle. */
	RUN(&r, "move", "3", "-5", "--speed", "60", "--yes", "--bus", "sim:1-3");
	assert_status(&r, 0, "move 3 -5");
	assert_has(r.out, "at -5.00 deg (target -5.00", "move 3 -5");
	run_free(&r);
}

/*
 * No --yes and no terminal: refuse before anything reaches the bus (--trace
 * prints every frame sent: none was).  The same holds for ROM writes.
 */
static const struct run_case unconfirmed[] = {
	{ .args = { "move", "2", "10", "--bus", "sim:1-3", "--trace" },
	  .status = 2,
	  .out_has = { "" },
	  .err_has = { "refusing to move motor 2", "--yes" },
	  .err_lacks = " TX " },
	{ .args = { "set-timeout", "2", "500", "--bus", "sim:1-3", "--trace" },
	  .status = 2,
	  .err_lacks = " TX " },
	{ .args = { "brake", "2", "off", "--bus", "sim:1-3", "--trace" },
	  .status = 2,
	  .err_lacks = " TX " },
};

static void test_move_unconfirmed(void **state)
{
	(void)state;
	run_cases_dev(unconfirmed, sizeof(unconfirmed) / sizeof(unconfirmed[0]));
}

static const struct run_case move_limits[] = {
	{ .args = { "move", "2", "10", "--speed", "500", "--yes", "--bus", "sim:1-3" },
	  .status = 2,
	  .err_has = { "--force" } },
	/* too far: it read its angle, never sent the move */
	{ .args = { "move", "2", "720", "--yes", "--bus", "sim:1-3", "--trace" },
	  .status = 2,
	  .err_lacks = "#A4" },
	{ .args = { "move", "2", "30", "--no-wait", "--yes", "--bus", "sim:1-3" },
	  .out_has = { "not waiting" } },
};

static void test_move_limits(void **state)
{
	(void)state;
	run_cases_dev(move_limits, sizeof(move_limits) / sizeof(move_limits[0]));
}

static void test_set_timeout(void **state)
{
	struct run r;

	(void)state;
	RUN(&r, "set-timeout", "2", "500", "--yes", "--bus", "sim:1-3", "--trace");
	assert_status(&r, 0, "set-timeout");
	assert_has(r.out, "500 ms", "set-timeout");
	assert_has(r.out, "echo verified", "set-timeout");
	/* V3 §2.30: 0xB3 with 500 = 0x1F4 at data[4..7], echoed. */
	assert_has(r.err, ") sim:1-3 142#B3000000F4010000\n# TX ", "set-timeout trace");
	assert_has(r.err, ") sim:1-3 242#B3000000F4010000\n# RX ", "set-timeout trace");
	run_free(&r);

	CHECK_RUN(.args = { "set-timeout", "7", "500", "--yes", "--bus", "sim:1-3" }, .status = 1,
		  .err_has = { "motor 7 did not answer 0xB3" });
	/* V3 §2.30 example 2: an answer of zeros is taken, the time said unverified */
	CHECK_RUN(.args = { "set-timeout", "2", "500", "--yes", "--bus", "sim:1-3", "--sim",
			    "b3_answer_zeros=yes" },
		  .out_has = { "answered with zeros (V3 §2.30 example 2): accepted, the time is "
			       "not verified" },
		  .out_lacks = "echo verified");
}

static const struct run_case other_commands[] = {
	{ .args = { "info", "1", "--bus", "sim:1-3", "--json" },
	  .out_has = { "\"model\":\"X8S2V10\"",
		       "\"accel_dps2\":", "\"position_kp\":", "\"timeout_ms\":null" } },
	{ .args = { "monitor", "1,5", "--once", "--bus", "sim:1-3" },
	  .status = 1,
	  .out_has = { "no answer" },
	  .out_lacks = "\033[" }, /* no screen control codes */
	{ .args = { "pid", "3", "10", "20", "30", "40", "50", "60", "--bus", "sim:1-3", "--json" },
	  .out_has = { "\"current_kp\":10," } },
	{ .args = { "accel", "3", "speed-accel", "20000", "--yes", "--bus", "sim:1-3" } },
	{ .args = { "set-id", "2", "9", "--yes", "--bus", "sim:2" },
	  .out_has = { "motor 2 is now motor 9" } },
	/* V3 0x79 reaches every motor: with others on the bus it refuses. */
	{ .args = { "set-id", "2", "9", "--yes", "--bus", "sim:1-3" },
	  .status = 1,
	  .err_has = { "3 motors answer" } },
	/*
	 * V4.2 §2.34.4: 0x20 index 5 on the motor's own id, echoed from the new
	 * id, then 0x76; no other motor hears it (docs/protocol-v4.md).
	 */
	{ .args = { "set-id", "2", "9", "--yes", "--bus", "sim:1-3", "--protocol", "v4",
		    "--trace" },
	  .out_has = { "motor 2 is now motor 9" },
	  .err_has = { "142#2005000009000000\n", "249#2005000009000000\n",
		       "142#7600000000000000\n" } },
	{ .args = { "set-id", "2", "3", "--yes", "--bus", "sim:1-3", "--protocol", "v4" },
	  .status = 1,
	  .err_has = { "id 3 is taken" } },
	/* V4.2 §2.1: seven float gains, one 0x30 by index each (the simulator's 1.0) */
	{ .args = { "pid", "1", "--bus", "sim:1-3", "--protocol", "v4", "--trace" },
	  .out_has = { "position kd", "current kp" },
	  .err_has = { "141#3001000000000000\n", "141#3009000000000000\n",
		       "241#300900000000803F\n" } },
	/* V4.2 §2.2: 1.5 is 0x3FC00000 (§2.2.5), 0.25 0x3E800000, each echoed */
	{ .args = { "pid", "1", "1.5", "2", "3", "4", "5", "6", "0.25", "--bus", "sim:1-3",
		    "--protocol", "v4", "--trace" },
	  .out_has = { "7 PID gains written to RAM" },
	  .err_has = { "141#310100000000C03F\n", "241#310100000000C03F\n",
		       "141#310900000000803E\n" } },
	/* info on a V4 motor: its seven gains by index, its 10-digit firmware date */
	{ .args = { "info", "1", "--bus", "sim:1-3", "--protocol", "v4" },
	  .out_has = { "sim:1-3 motor 1 (v4)", "firmware date    2025070202", "position kd" } },
	/* a firmware date that names another generation says which --protocol it needs */
	{ .args = { "info", "1", "--bus", "sim:1", "--protocol", "v4", "--sim",
		    "version_date=20220206" },
	  .out_has = { "sim:1 motor 1 (v4; its firmware date says v3: --protocol v3)" } },
	{ .args = { "info", "1", "--bus", "sim:1", "--protocol", "v3", "--sim",
		    "version_date=2025070202" },
	  .out_has = { "sim:1 motor 1 (v3; its firmware date says v4: --protocol v4)" } },
	{ .args = { "pid", "1", "1", "2", "--bus", "sim:1-3", "--protocol", "v4" },
	  .status = 2,
	  .err_has = { "POS_KI [POS_KD]" } },
	{ .args = { "reset", "1", "--bus", "sim:1-3" } },
	/* V2 has no 0xB5 */
	{ .args = { "scan", "--protocol", "v2", "--bus", "sim:1-2", "--json" },
	  .out_has = { "\"protocol\":\"v2\"", "\"model\":null" } },
};

static void test_other_commands(void **state)
{
	struct run r;

	(void)state;
	RUN(&r, "monitor", "--once", "--json", "--bus", "sim");
	assert_status(&r, 0, "monitor --once");
	assert_int_equal(count_lines(r.out), 4); /* plain "sim": motors 1..4 */
	assert_has(r.out, "\"motor_id\":4,", "monitor --once");
	run_free(&r);

	run_cases_dev(other_commands, sizeof(other_commands) / sizeof(other_commands[0]));
}

static void test_usage_errors(void **state)
{
	static const char *const bad[][10] = {
		{ "status", "--bus", "sim", NULL },
		{ "status", "0", "--bus", "sim", NULL },
		{ "status", "33", "--bus", "sim", NULL },
		{ "status", "1", "2", "--bus", "sim", NULL },
		{ "status", "1", "--bogus", NULL },
		{ "status", "1", "--rom", "--bus", "sim", NULL },
		{ "status", "1", "--timeout", "0", NULL },
		{ "status", "1", "--tries", NULL },
		{ "move", "1", "abc", "--bus", "sim", NULL },
		{ "move", "1", "--bus", "sim", NULL },
		{ "brake", "1", "maybe", "--bus", "sim", NULL },
		{ "pid", "1", "300", "1", "1", "1", "1", "1", NULL },
		{ "pid", "1", "1", "2", "--bus", "sim", NULL },
		{ "accel", "1", "9", "500", "--bus", "sim", NULL },
		{ "set-id", "3", "3", "--bus", "sim", NULL },
		{ "set-timeout", "1", "-5", "--bus", "sim", NULL },
		{ "scan", "1-40", "--bus", "sim", NULL },
		{ "scan", "--protocol", "v9", NULL },
	};

	(void)state;
	for (size_t i = 0; i < sizeof(bad) / sizeof(bad[0]); i++) {
		struct run r;
		char what[128];

		snprintf(what, sizeof(what), "%s %s %s", bad[i][0], bad[i][1] ? bad[i][1] : "",
			 bad[i][1] && bad[i][2] ? bad[i][2] : "");
		run_argv(&r, bad[i]);
		assert_status(&r, 2, what);
		assert_has(r.err, "rmdctl ", what);
		run_free(&r);
	}
}

static const struct run_case help[] = {
	{ .args = { "--help" }, .out_has = { "scan", "move" } },
	{ .args = { "move", "--help" },
	  .out_has = { "usage: rmdctl move", "--yes", "nothing persists" } },
	{ .args = { "help", "scan" }, .out_has = { "usage: rmdctl scan" } },
};

static void test_help(void **state)
{
	(void)state;
	run_cases_dev(help, sizeof(help) / sizeof(help[0]));
}

/* A bus that cannot be opened: exit 1 with the transport's message. */
static const struct run_case bus_errors[] = {
	{ .args = { "status", "1", "--bus", "/dev/ttyRMDnone" },
	  .status = 1,
	  .err_has = { "/dev/ttyRMDnone" } },
	{ .args = { "status", "1", "--bus", "rmdnone0" }, .status = 1, .err_has = { "rmdnone0" } },
};

static void test_bus_errors(void **state)
{
	(void)state;
	run_cases_dev(bus_errors, sizeof(bus_errors) / sizeof(bus_errors[0]));
}

static int group_setup(void **state)
{
	(void)state;
	return sleeper_start(&ref, REF_PERIOD_MS * MS, 0);
}

static int group_teardown(void **state)
{
	(void)state;
	sleeper_stop(&ref);
	return 0;
}

/* Process tests need the built binary. */
static int need_rmdctl(void **state)
{
	(void)state;
	return find_prog(rmdctl, sizeof(rmdctl), "RMDCTL", "rmdctl");
}

#define PROC_TEST(f) cmocka_unit_test_setup(f, need_rmdctl)

int main(void)
{
	const struct CMUnitTest tests[] = {
		cmocka_unit_test(test_sim_ops_basics),
		cmocka_unit_test(test_sim_ops_reply_timing),
		cmocka_unit_test(test_sim_ops_pipelined),
		cmocka_unit_test(test_sim_ops_txqueue),
		cmocka_unit_test(test_sim_ops_bus_off),
		cmocka_unit_test(test_sim_open_errors),
		cmocka_unit_test(test_parse_ids),
		cmocka_unit_test(test_open_spec),
		cmocka_unit_test(test_txn_sim),
		cmocka_unit_test(test_txn_matching),
		PROC_TEST(test_scan),
		PROC_TEST(test_status),
		PROC_TEST(test_status_missing),
		PROC_TEST(test_slow_adapter),
		PROC_TEST(test_set_id_writes_once),
		PROC_TEST(test_set_id_reboot),
		PROC_TEST(test_set_id_personalities),
		PROC_TEST(test_characterize),
		PROC_TEST(test_move),
		PROC_TEST(test_move_unconfirmed),
		PROC_TEST(test_move_limits),
		PROC_TEST(test_set_timeout),
		PROC_TEST(test_other_commands),
		PROC_TEST(test_usage_errors),
		PROC_TEST(test_help),
		PROC_TEST(test_bus_errors),
	};

	cmocka_set_test_filter(getenv("RMD_TEST_FILTER"));
	return cmocka_run_group_tests_name("rmdctl_dev", tests, group_setup, group_teardown);
}
