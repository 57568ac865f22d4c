// SPDX-License-Identifier: MIT
/*
 * rmdctl brake, stop, off, reset, move: commands that change what the
 * motor does.  Non-rt.
 */
#include <inttypes.h>
#include <math.h>
#include <stdint.h>
#include <stdio.h>
#include <string.h>
#include <unistd.h>

#include "rmd/time.h"
#include "rmd/codec.h"
#include "rmd/describe.h"
#include "rmdctl.h"

/* move: a bench move is small and slow unless --force */
#define MOVE_SPEED_CAP_DPS 90.0
#define MOVE_TRAVEL_CAP_DEG 360.0
#define MOVE_TOL_DEG 0.2
#define MOVE_POLL_NS 20000000
#define MOVE_SETTLE_NS 1000000000 /* no progress this long: it stopped short */
#define MOVE_SLACK_NS 3000000000  /* beyond travel / speed * 1.5 */
/* reset: how long a motor may take to answer again */
#define RESET_WAIT_NS 3000000000
#define RESET_POLL_NS 50000000

/* ---- brake, stop, off, reset ---------------------------------------------------------- */

/* One echoing command with a one-line report. */
static int simple(struct dev *d, uint8_t id, uint8_t cmd, const char *done)
{
	struct req q;
	int r;

	r = rmdctl_open_bus(d);
	if (r)
		return r;
	rmdctl_req_init(&q, id, cmd);
	r = rmdctl_ask(d, &q);
	if (!r)
		printf("%s: motor %u: %s (0x%02X)\n", d->name, id, done, cmd);
	rmdctl_close_bus(d);
	return r;
}

int rmdctl_run_brake(struct dev *d, int argc, char **argv)
{
	bool lock;
	struct req q;
	uint8_t id = d->id;
	int r;

	(void)argc;
	if (!strcmp(argv[1], "on") || !strcmp(argv[1], "lock")) {
		lock = true;
	} else if (!strcmp(argv[1], "off") || !strcmp(argv[1], "release")) {
		lock = false;
	} else {
		tool_log(TOOL_LOG_ERR, "bad state \"%s\" (on = locked, off = released)", argv[1]);
		return RMDCTL_EXIT_USAGE;
	}
	/* V3 §2.27 / V2 §3.51: locking moves nothing. */
	if (lock)
		return simple(d, id, 0x78, "brake locked");
	/* V3 §2.26: a released brake lets the load move the shaft. */
	r = rmdctl_open_bus_for(d, true, "release the brake of motor %u on %s", id, d->bus_spec);
	if (r)
		return r;
	r = rmdctl_confirm(d, "release the brake of motor %u on %s (the load may move the shaft)",
			   id, d->name);
	if (!r) {
		rmdctl_req_init(&q, id, 0x77);
		r = rmdctl_ask(d, &q);
		if (!r)
			printf("%s: motor %u: brake released (0x77)\n", d->name, id);
	}
	rmdctl_close_bus(d);
	return r;
}

int rmdctl_run_stop(struct dev *d, int argc, char **argv)
{
	(void)argc;
	(void)argv;
	/* V3 §2.16 / V2 §3.35: decelerate and hold. */
	return simple(d, d->id, 0x81, "stopped, holding position");
}

int rmdctl_run_off(struct dev *d, int argc, char **argv)
{
	(void)argc;
	(void)argv;
	/* V3 §2.15 / V2 §3.34: output off, state cleared. */
	return simple(d, d->id, 0x80, "output off");
}

int rmdctl_run_reset(struct dev *d, int argc, char **argv)
{
	const struct rmd_cmd_spec *reset = rmd_cmd_find(d->proto, 0x76);
	/* V3 §2.25: no answer; V2 §3.49: echoes, then resets (the row says which) */
	bool answers = reset && !(reset->flags & RMD_CMD_NO_REPLY);
	/* V3 §2.28: the runtime restarts at 0; V2 has only 0x9A */
	bool runtime = rmd_cmd_find(d->proto, 0xB1) != NULL;
	int64_t t_reset, until;
	struct req q;
	uint8_t id = d->id;
	int r;

	(void)argc;
	(void)argv;
	r = rmdctl_open_bus(d);
	if (r)
		return r;
	/* V3 §2.25: no answer; V2 §3.49: echoes, then resets. */
	rmdctl_req_init(&q, id, 0x76);
	r = answers ? rmdctl_ask(d, &q) : rmdctl_run_reqs(d, &q, 1);
	if (r)
		goto out;
	t_reset = rmd_now_ns();
	until = t_reset + RESET_WAIT_NS;
	/* Back when it answers again: V3 runtime (0xB1) restarts at 0; V2 has only 0x9A. */
	r = RMDCTL_EXIT_DATA;
	do {
		int64_t now;

		rmdctl_req_init(&q, id, runtime ? 0xB1 : 0x9A);
		if (rmdctl_run_reqs(d, &q, 1))
			goto out;
		now = rmd_now_ns();
		if (q.ok &&
		    (!runtime || q.rep.v[RMD_FLD_RUNTIME] <= (now - t_reset) / 1000000 + 100)) {
			printf("%s: motor %u: reset (0x76), answering again after %.0f ms%s\n",
			       d->name, id, (double)(now - t_reset) / 1e6,
			       runtime ? "; multi-turn position restarts within +-180 deg" : "");
			r = RMDCTL_EXIT_OK;
			goto out;
		}
		rmdctl_sleep_until(now + RESET_POLL_NS);
	} while (rmd_now_ns() < until && !rmdctl_interrupted);
	tool_log(TOOL_LOG_ERR, "%s: motor %u: sent 0x76, but it did not answer again within %.0f s",
		 d->name, id, RESET_WAIT_NS / 1e9);
out:
	rmdctl_close_bus(d);
	return r;
}

/* ---- move ----------------------------------------------------------------------------- */

/* The multi-turn angle (0x92), in deg.  Returns 0 or RMDCTL_EXIT_DATA (reported). */
static int read_angle(struct dev *d, uint8_t id, double *deg)
{
	struct rec rec = { 0 };
	struct req q;
	int r;

	rmdctl_req_init(&q, id, 0x92);
	r = rmdctl_ask(d, &q);
	if (r)
		return r;
	rmdctl_rec_add_req(&rec, d, &q, true);
	if (!rmdctl_rec_has(&rec, RMD_FLD_ANGLE))
		return RMDCTL_EXIT_DATA;
	*deg = rmdctl_rec_val(&rec, RMD_FLD_ANGLE);
	return 0;
}

/* Ctrl-C or a move gone wrong: V3 §2.16 stop and hold, whatever rmdctl_interrupted the rest. */
void rmdctl_stop_motor(struct dev *d, uint8_t id)
{
	struct rmd_txn_opts o = d->txn;
	struct rmd_txn t;
	struct rmd_msg m = { .cmd = 0x81 };

	o.stop = NULL;
	if (rmd_txn_prepare(&t, d->proto, id, &m) == 0 && rmd_txn_run(d->b, &t, 1, &o) == 1)
		tool_log(TOOL_LOG_ERR, "%s: motor %u stopped (0x81), holding position", d->name,
			 id);
	else
		tool_log(TOOL_LOG_ERR, "%s: motor %u: stop (0x81) not acknowledged", d->name, id);
}

/*
 * On a terminal (stdout), one line that move_wait() rewrites as the motor
 * goes: "can0: motor 3: 45.20 deg of 90.00 (50 %), 1.5 s"; NULL erases it.
 * Nothing when stdout is a file, a pipe, or --json.
 */
static void move_progress(const struct dev *d, uint8_t id, const double *deg, double from,
			  double target, int64_t since_ns)
{
	double travel = fabs(target - from);

	if (d->json || !isatty(STDOUT_FILENO))
		return;
	if (!deg) {
		fputs("\r\033[K", stdout);
		return;
	}
	printf("\r%s: motor %u: %.2f deg of %.2f (%.0f %%), %.1f s\033[K", d->name, id, *deg,
	       target, travel > 0 ? 100.0 * fmin(1.0, fabs(*deg - from) / travel) : 100.0,
	       (double)(rmd_now_ns() - since_ns) / 1e9);
	fflush(stdout);
}

/* Poll 0x92 until the motor is within MOVE_TOL_DEG of target, stops short, or time runs out. */
static int move_poll(struct dev *d, uint8_t id, double from, double target, double *final,
		     const char **why)
{
	double travel = fabs(target - from), last = from;
	int64_t t0 = rmd_now_ns(), last_progress = t0;
	int64_t limit = t0 + (int64_t)(travel / d->speed_dps * 1.5e9) + MOVE_SLACK_NS;
	unsigned near = 0;
	int r;

	*final = from;
	for (;;) {
		int64_t now;

		rmdctl_sleep_until(rmd_now_ns() + MOVE_POLL_NS);
		if (rmdctl_interrupted) {
			*why = "interrupted";
			return RMDCTL_EXIT_DATA;
		}
		r = read_angle(d, id, final);
		if (r) {
			*why = rmdctl_interrupted ? "interrupted" : "lost contact";
			return r;
		}
		now = rmd_now_ns();
		move_progress(d, id, final, from, target, t0);
		/* Two polls in a row within tolerance: arrived and settled. */
		near = fabs(*final - target) <= MOVE_TOL_DEG ? near + 1 : 0;
		if (near >= 2)
			return 0;
		if (fabs(*final - last) > 0.05) {
			last = *final;
			last_progress = now;
		} else if (now - last_progress > MOVE_SETTLE_NS) {
			*why = "stopped short";
			return RMDCTL_EXIT_DATA;
		}
		if (now > limit) {
			*why = "timed out";
			return RMDCTL_EXIT_DATA;
		}
	}
}

/* move_poll(), with the progress line of a terminal erased after it. */
int rmdctl_move_wait(struct dev *d, uint8_t id, double from, double target, double *final,
		     const char **why)
{
	int r = move_poll(d, id, from, target, final, why);

	move_progress(d, id, NULL, from, target, 0);
	return r;
}

int rmdctl_run_move(struct dev *d, int argc, char **argv)
{
	const struct rmd_cmd_spec *spec = rmdctl_spec(d, 0xA4);
	double target, from, final;
	struct rec rec = { 0 };
	struct req q[2];
	const char *why = "";
	bool release;
	int64_t t0;
	uint8_t id = d->id;
	int r;

	(void)argc;
	if (rmdctl_parse_double(argv[1], &target) < 0 || fabs(target) > 1e6) {
		tool_log(TOOL_LOG_ERR, "bad DEG \"%s\" (an angle in degrees)", argv[1]);
		return RMDCTL_EXIT_USAGE;
	}
	if (!(d->speed_dps >= 1) || d->speed_dps > UINT16_MAX) {
		tool_log(TOOL_LOG_ERR, "bad --speed %g (1..%u dps)", d->speed_dps, UINT16_MAX);
		return RMDCTL_EXIT_USAGE;
	}
	if (d->speed_dps > MOVE_SPEED_CAP_DPS && !d->force) {
		tool_log(TOOL_LOG_ERR,
			 "refusing --speed %g dps: bench moves are capped at %g dps (add --force)",
			 d->speed_dps, MOVE_SPEED_CAP_DPS);
		return RMDCTL_EXIT_USAGE;
	}
	r = rmdctl_open_bus_for(d, true, "move motor %u on %s", id, d->bus_spec);
	if (r)
		return r;
	/* Where it is, and whether its brake would hold it (V3 §2.12: data[3]). */
	rmdctl_req_init(&q[0], id, 0x92);
	rmdctl_req_init(&q[1], id, 0x9A);
	r = rmdctl_run_reqs(d, q, 2);
	if (r)
		goto out;
	if (rmdctl_report_failed(d, q, 2)) {
		r = RMDCTL_EXIT_DATA;
		goto out;
	}
	rmdctl_rec_add_req(&rec, d, &q[0], true);
	rmdctl_rec_add_req(&rec, d, &q[1], true);
	from = rmdctl_rec_val(&rec, RMD_FLD_ANGLE);
	/* V2 §3.31 does not report the brake: release it anyway (0x77 only echoes without one). */
	release = !rmdctl_rec_has(&rec, RMD_FLD_BRAKE) || rec.raw[RMD_FLD_BRAKE] == 0;
	if (rmdctl_rec_has(&rec, RMD_FLD_ERROR) && rec.raw[RMD_FLD_ERROR] && !d->force) {
		char e[128];

		tool_log(TOOL_LOG_ERR,
			 "%s: motor %u reports errors %s: not moving it (add --force)", d->name, id,
			 rmdctl_errors_text(d, rec.raw[RMD_FLD_ERROR], e, sizeof(e)));
		r = RMDCTL_EXIT_DATA;
		goto out;
	}
	if (fabs(target - from) > MOVE_TRAVEL_CAP_DEG && !d->force) {
		tool_log(TOOL_LOG_ERR,
			 "refusing to move motor %u by %.2f deg (from %.2f to %.2f): bench "
			 "moves are capped at %g deg (add --force)",
			 id, target - from, from, target, MOVE_TRAVEL_CAP_DEG);
		r = RMDCTL_EXIT_USAGE;
		goto out;
	}
	r = rmdctl_confirm(d, "move motor %u on %s from %.2f to %.2f deg at %g dps%s", id, d->name,
			   from, target, d->speed_dps, release ? " (releases its brake)" : "");
	if (r)
		goto out;
	if (release) {
		/* The sim and braked motors hold the shaft while the brake is locked (V3 §2.26). */
		rmdctl_req_init(&q[0], id, 0x77);
		r = rmdctl_ask(d, &q[0]);
		if (r)
			goto out;
	}
	/* V3 §2.20 / V2 §3.40: absolute position, speed limited. */
	rmdctl_req_init(&q[0], id, 0xA4);
	if (rmd_msg_set_native(&q[0].msg, spec, RMD_DIR_REQUEST, RMD_FLD_MAX_SPEED, d->speed_dps) <
		    0 ||
	    rmd_msg_set_native(&q[0].msg, spec, RMD_DIR_REQUEST, RMD_FLD_ANGLE, target) < 0) {
		tool_log(TOOL_LOG_ERR, "cannot encode 0xA4 to %g deg at %g dps", target,
			 d->speed_dps);
		r = RMDCTL_EXIT_USAGE;
		goto out;
	}
	t0 = rmd_now_ns();
	r = rmdctl_ask(d, &q[0]);
	if (r)
		goto out;
	if (d->no_wait) {
		if (d->json) {
			rmdctl_json_begin(d, id);
			printf(",\"from_deg\":%.2f,\"target_deg\":%.2f,\"waited\":false}\n", from,
			       target);
		} else {
			printf("%s: motor %u: moving from %.2f to %.2f deg at %g dps (not waiting)\n",
			       d->name, id, from, target, d->speed_dps);
		}
		goto out;
	}
	r = rmdctl_move_wait(d, id, from, target, &final, &why);
	if (r) {
		/* Make sure nothing keeps moving after we stop watching. */
		rmdctl_stop_motor(d, id);
		tool_log(TOOL_LOG_ERR, "%s: motor %u: %s at %.2f deg (target %.2f deg)", d->name,
			 id, why, final, target);
		goto out;
	}
	if (d->json) {
		rmdctl_json_begin(d, id);
		printf(",\"from_deg\":%.2f,\"target_deg\":%.2f,\"angle_deg\":%.2f,\"arrived\":true,"
		       "\"elapsed_s\":%.3f}\n",
		       from, target, final, (double)(rmd_now_ns() - t0) / 1e9);
	} else {
		printf("%s: motor %u: at %.2f deg (target %.2f, from %.2f) after %.2f s, holding "
		       "position\n",
		       d->name, id, final, target, from, (double)(rmd_now_ns() - t0) / 1e9);
	}
out:
	rmdctl_close_bus(d);
	return r;
}
