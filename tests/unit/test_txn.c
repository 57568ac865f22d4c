// SPDX-License-Identifier: MIT
/*
 * Transactions (rmd/txn.h) against frames that repeat their request: a
 * motor whose comm-loss protection tripped echoes the first command it
 * gets, and some answers are byte for byte their request (V3 §2.8: 0x62
 * with offset 0).  On the in-process simulated bus (its motors' comm-loss
 * protection and echo are src/sim's), with the harness clock: every run
 * is the same on every machine, and times are sim times.
 */
#include <errno.h>
#include <setjmp.h>
#include <stdarg.h>
#include <stddef.h>
#include <stdint.h>
#include <string.h>

#include <cmocka.h>

#include "rmd/bus_sim.h"
#include "rmd/codec.h"
#include "rmd/txn.h"
#include "harness/clock.h"
#include "harness/suite.h"

#define MS INT64_C(1000000)
/* The comm-loss time test_rmdctl_rs485's dump/restore writes to motor 2. */
#define COMM_LOSS_MS 300
/* A per-try timeout longer than that: a try left waiting lets the motor trip again. */
#define LONG_TIMEOUT_MS 500

struct fix {
	struct rmd_bus bus;
	struct rmd_sim_motor_params p;
	struct rmd_txn_opts o;
};

/* A V3 motor 2 (rmd-sim's defaults: gains 85/25, zero offset 0), tripped or not. */
static void open_motor(struct fix *x, bool tripped)
{
	struct rmd_bus_sim_motor m = { .id = 2, .proto = RMD_PROTO_V3, .params = &x->p };
	struct rmd_bus_sim_opts so = { .motors = &m, .n_motors = 1 };
	char err[256];

	memset(x, 0, sizeof(*x));
	rmd_sim_motor_params_default(&x->p, 2, RMD_PROTO_V3);
	x->p.comm_loss_rom_ms = COMM_LOSS_MS;
	x->p.comm_loss_tripped = tripped;
	assert_int_equal(rmd_bus_sim_open(&x->bus, "s0", &so, err, sizeof(err)), 0);
	t_now = 1000 * MS;
	x->o = (struct rmd_txn_opts){ .timeout_ns = LONG_TIMEOUT_MS * MS,
				      .tries = RMD_TXN_TRIES,
				      .now_ns = fake_now,
				      .sleep_ns = fake_sleep };
}

static void prepare(struct rmd_txn *t, const uint8_t *cmds, unsigned n)
{
	for (unsigned i = 0; i < n; i++) {
		struct rmd_msg m = { .cmd = cmds[i] };

		assert_int_equal(rmd_txn_prepare(&t[i], RMD_PROTO_V3, 2, &m), 0);
	}
}

/* t[0..n) for cmds, run to completion (every one answered); returns the sim time it took. */
static int64_t run_all(struct fix *x, struct rmd_txn *t, const uint8_t *cmds, unsigned n)
{
	int64_t t0 = t_now;

	prepare(t, cmds, n);
	assert_int_equal(rmd_txn_run(&x->bus, t, n, &x->o), (int)n);
	return t_now - t0;
}

static void decode(const struct rmd_txn *t, struct rmd_msg *m)
{
	assert_true(t->done);
	assert_int_equal(rmd_decode_as(RMD_PROTO_V3, RMD_DIR_REPLY, t->req.data[0], &t->rep.f, m),
			 0);
}

/*
 * rmdctl dump's batch to a tripped motor with --timeout above its
 * comm-loss time: 0x30 is echoed, and a try that waited out the timeout
 * before going again was echoed again and taken as the gains (all zero).
 */
static void test_tripped_echo_is_no_answer(void **state)
{
	static const uint8_t cmds[] = { 0x30, 0x42, 0x62, 0xB5, 0xB2 };
	struct rmd_txn t[5];
	struct rmd_msg m;
	struct fix x;
	int64_t took_ns;

	(void)state;
	open_motor(&x, true);
	took_ns = run_all(&x, t, cmds, 5);
	decode(&t[0], &m);
	assert_int_equal(m.v[RMD_FLD_CURR_KP], 85);
	assert_int_equal(m.v[RMD_FLD_CURR_KI], 25);
	assert_int_equal(m.v[RMD_FLD_POS_KI], 25);
	/* sent again at once, behind a guard, not after the timeout */
	assert_int_equal(t[0].tries, 2);
	assert_true(t[0].echo_seen);
	assert_true(took_ns < COMM_LOSS_MS * MS);
	/* 0x62 went right behind 0x42, which was answered: its zeros are the answer */
	decode(&t[2], &m);
	assert_int_equal(m.v[RMD_FLD_ENCODER_OFF], 0);
	assert_int_equal(t[2].tries, 1);
	rmd_bus_close(&x.bus);
}

/*
 * `cmd` alone to motor 2, tripped or not: answered at the second try, sent
 * at once behind its guard; m gets the answer.  Returns the sim time taken.
 */
static int64_t read_alone(bool tripped, uint8_t cmd, struct rmd_msg *m)
{
	struct rmd_txn t;
	struct fix x;
	int64_t took_ns;

	open_motor(&x, tripped);
	took_ns = run_all(&x, &t, &cmd, 1);
	decode(&t, m);
	assert_int_equal(t.tries, 2);
	assert_true(t.echo_seen);
	rmd_bus_close(&x.bus);
	return took_ns;
}

/*
 * Bring-up's and rmdctl's probe (0x9A) of a tripped motor: its echo, taken
 * after the motor tripped again, read as a status of 0 V.
 */
static void test_tripped_status_read(void **state)
{
	struct rmd_msg m;

	(void)state;
	assert_true(read_alone(true, 0x9A, &m) < COMM_LOSS_MS * MS);
	assert_true(m.v[RMD_FLD_VOLTAGE] > 0);
}

/*
 * V3 §2.8: 0x62's answer with offset 0 repeats its request.  Alone, it is
 * sent again at once behind a guard and taken: two exchanges and a
 * guard's, a few ms, far from the 500 ms timeout.
 */
static void test_zero_answer_alone(void **state)
{
	struct rmd_msg m;

	(void)state;
	assert_true(read_alone(false, 0x62, &m) < 10 * MS);
	assert_int_equal(m.v[RMD_FLD_ENCODER_OFF], 0);
}

/* One try only: the echo is all that came, and it is not taken. */
static void test_only_echoed(void **state)
{
	static const uint8_t cmds[] = { 0x30 };
	struct rmd_txn t;
	struct fix x;

	(void)state;
	open_motor(&x, true);
	x.o.tries = 1;
	prepare(&t, cmds, 1);
	assert_int_equal(rmd_txn_run(&x.bus, &t, 1, &x.o), 0);
	assert_false(t.done);
	assert_true(t.echo_seen);
	assert_int_equal(t.tries, 1);
	rmd_bus_close(&x.bus);
}

/*
 * V3 §4.3: 0x79's write answers with its request, on 0x300, where no 0x9A
 * can go ahead of it: the repeat of a resend made at once is the answer.
 */
static void test_set_id_repeat(void **state)
{
	struct rmd_msg w = { .cmd = 0x79 };
	struct rmd_txn t;
	struct fix x;
	int64_t t0;

	(void)state;
	open_motor(&x, false);
	rmd_msg_set(&w, RMD_FLD_READ_FLAG, 0);
	rmd_msg_set(&w, RMD_FLD_CAN_ID, 2); /* its own id: nothing changes */
	assert_int_equal(rmd_txn_prepare(&t, RMD_PROTO_V3, 2, &w), 0);
	assert_false(t.guardable);
	t0 = t_now;
	assert_int_equal(rmd_txn_run(&x.bus, &t, 1, &x.o), 1);
	assert_memory_equal(t.rep.f.data, t.req.data, RMD_FRAME_LEN);
	assert_int_equal(t.tries, 2);
	assert_true(t_now - t0 < 10 * MS);
	rmd_bus_close(&x.bus);
}

/* Right behind another request to the motor, 0x62's zeros are taken at the first try. */
static void test_zero_answer_in_batch(void **state)
{
	static const uint8_t cmds[] = { 0x9A, 0x62 };
	struct rmd_txn t[2];
	struct rmd_msg m;
	struct fix x;

	(void)state;
	open_motor(&x, false);
	assert_true(run_all(&x, t, cmds, 2) < 10 * MS);
	decode(&t[1], &m);
	assert_int_equal(m.v[RMD_FLD_ENCODER_OFF], 0);
	assert_int_equal(t[1].tries, 1);
	assert_false(t[1].echo_seen);
	rmd_bus_close(&x.bus);
}

/*
 * `cmd` alone to motor 2, tripped or not, with a per-try timeout shorter
 * than the motor's turnaround (a loaded machine, an emulated guest):
 * every answer comes after its try was given up and sent again.  A late
 * repeat (0x62's zeros, a trip's echo) is an earlier try's, not an echo
 * of the resend: the answer is taken within the tries, never "only
 * echoed".  Returns it in m; whether any frame was taken for an echo.
 */
static bool late_read(bool tripped, uint8_t cmd, struct rmd_msg *m)
{
	struct rmd_txn t;
	struct fix x;

	open_motor(&x, tripped);
	x.o.timeout_ns = 300000; /* under the sim's 0.5 ms turnaround */
	prepare(&t, &cmd, 1);
	assert_int_equal(rmd_txn_run(&x.bus, &t, 1, &x.o), 1);
	decode(&t, m);
	rmd_bus_close(&x.bus);
	return t.echo_seen;
}

static void test_late_zero_answer(void **state)
{
	struct rmd_msg m;

	(void)state;
	assert_false(late_read(false, 0x62, &m));
	assert_int_equal(m.v[RMD_FLD_ENCODER_OFF], 0);
}

/* The same, tripped: the first try's late echo is passed over too. */
static void test_late_echo(void **state)
{
	struct rmd_msg m;

	(void)state;
	(void)late_read(true, 0x30, &m);
	assert_int_equal(m.v[RMD_FLD_CURR_KP], 85);
}

/*
 * A write whose answer is its echo, to a tripped motor: `rmdctl
 * set-timeout 2 0`.  The motor echoes the first command it gets without
 * executing it; that echo looked like the write's answer.  A guard goes
 * ahead of it, so the write is executed: with the protection off, a read
 * a long silence later is answered at the first try, not echoed.
 */
static void test_tripped_write_executes(void **state)
{
	static const uint8_t cmds[] = { 0x30 };
	struct rmd_msg w = { .cmd = 0xB3 };
	struct rmd_txn t;
	struct fix x;

	(void)state;
	open_motor(&x, true);
	rmd_msg_set(&w, RMD_FLD_TIMEOUT, 0);
	assert_int_equal(rmd_txn_prepare(&t, RMD_PROTO_V3, 2, &w), 0);
	assert_int_equal(rmd_txn_run(&x.bus, &t, 1, &x.o), 1);
	assert_memory_equal(t.rep.f.data, t.req.data, RMD_FRAME_LEN);
	t_now += 2 * COMM_LOSS_MS * MS;
	x.o.tries = 1;
	prepare(&t, cmds, 1);
	assert_int_equal(rmd_txn_run(&x.bus, &t, 1, &x.o), 1);
	assert_false(t.echo_seen);
	rmd_bus_close(&x.bus);
}

SUITE_MAIN("txn", NULL, NULL,
	   {
		   cmocka_unit_test(test_tripped_echo_is_no_answer),
		   cmocka_unit_test(test_tripped_status_read),
		   cmocka_unit_test(test_only_echoed),
		   cmocka_unit_test(test_zero_answer_alone),
		   cmocka_unit_test(test_zero_answer_in_batch),
		   cmocka_unit_test(test_set_id_repeat),
		   cmocka_unit_test(test_late_zero_answer),
		   cmocka_unit_test(test_late_echo),
		   cmocka_unit_test(test_tripped_write_executes),
	   })
