// SPDX-License-Identifier: MIT
/*
 * An e-stop on real SocketCAN, in the VM (issue 33 point 4;
 * harness/vsys.h): rmd-sim's motors on vcan2 lose power while the test
 * writes what an adapter reports when nobody acknowledges: no motion frame
 * of rmdd's to them in candump from then until each echoed 0xB3 again
 * after power returned; rmdd logs it, health_t says it, vcan2 restarted.
 */
#define _GNU_SOURCE
#include <errno.h>
#include <setjmp.h>
#include <stdarg.h>
#include <stdbool.h>
#include <stddef.h>
#include <stdint.h>
#include <stdio.h>
#include <string.h>
#include <unistd.h>

#include <sys/types.h>

#include <linux/can.h>
#include <linux/can/error.h>

#include <cmocka.h>

#include "rmd/time.h"
#include "rmd/codec.h"

#include "harness/vsys.h"

/* ---- issue 33 point 4: an e-stop, on vcan ---------------------------------------- */

#define CUT_S 10	/* rmd-sim's motors lose power this long after its start ... */
#define CUT_LEN_S 3	/* ... for this long (bus_power) */
#define ACK_EVERY_MS 10 /* the test writes the adapter's report this often */

/*
 * What a CAN adapter reports when nobody acknowledges its frames (an
 * e-stop): its transmitter error-passive (CAN_ERR_CRTL_TX_PASSIVE) and an
 * ACK error (CAN_ERR_ACK, berr-reporting on).  vcan acknowledges
 * everything and reports nothing, so the test writes them on the bus, as
 * test_bus_socketcan.c does; rmdd's socket takes error frames from any
 * writer.
 */
static void no_ack_report(unsigned b)
{
	struct can_frame cf[2] = {
		{ .can_id = CAN_ERR_FLAG | CAN_ERR_CRTL, .len = CAN_ERR_DLC },
		{ .can_id = CAN_ERR_FLAG | CAN_ERR_ACK, .len = CAN_ERR_DLC },
	};

	cf[0].data[1] = CAN_ERR_CRTL_TX_PASSIVE;
	for (unsigned k = 0; k < 2; k++) {
		ssize_t w = write(S.log.can_fd[b], &cf[k], sizeof(cf[k]));

		if (w < 0 && errno == ENETDOWN) /* stale: rmdd restarted the interface */
			w = write(S.log.can_fd[b], &cf[k], sizeof(cf[k]));
		if (w < 0 && errno != ENETDOWN && errno != ENOBUFS)
			fail_msg("%s: write an error frame: %s", iface(b), strerror(errno));
	}
}

/* f is a frame that moves motor i: 0xA1..0xA8, 0x77, 0x81, 0x88 to it, MIT, 0x280. */
static bool moves_motor(const struct cframe *f, unsigned i)
{
	uint8_t c = f->data[0];

	if (f->bus != S.cfg.motors[i].bus)
		return false;
	if (f->id == RMD_CAN_MULTI || f->id == RMD_CAN_MIT_REQ_BASE + S.cfg.motors[i].id)
		return true;
	return f->id == req_id(i) &&
	       ((c >= 0xA1 && c <= 0xA8) || c == 0x77 || c == 0x81 || c == 0x88);
}

/*
 * rmd-sim's motors on vcan2 (c1, c2) lose power CUT_S after its start for
 * CUT_LEN_S (bus_power; they boot at the end, their RAM state lost), the
 * controller streaming its setpoints all along.  From the moment rmd-sim
 * says the cut began, the test writes the adapter's report
 * (no_ack_report()) every ACK_EVERY_MS until just before power returns.  Judged on candump's log: no frame
 * that moves c1 or c2 from two of rmdd's periods (plus the worst delay the
 * guest imposed at the loop's priority) after the first report, until that
 * motor's echo of 0xB3 after power returned; and they do run again.
 * rmdd's journal says it ("no node acknowledges", "the frames it still
 * held are dropped": as root in the guest it restarts vcan2), health_t
 * shows BUS_NO_ACK.  What vcan cannot show is a real controller's: its
 * error frames, the frames its queue and buffers held, that restarting the
 * interface empties them (docs/faults.md "E-stop").
 */
/* The last frame that moves motor i in [t0, t1), or NULL. */
static const struct cframe *last_move(unsigned i, int64_t t0, int64_t t1)
{
	const struct cframe *best = NULL;

	for (size_t n = 0; n < S.log.nframes; n++)
		if (moves_motor(&S.log.frames[n], i) && S.log.frames[n].t_ns >= t0 &&
		    S.log.frames[n].t_ns < t1 && (!best || S.log.frames[n].t_ns > best->t_ns))
			best = &S.log.frames[n];
	return best;
}

/*
 * Restart rmd-sim on bus b with `fault` (bus_power from cut_s), and have
 * every motor ENABLED again before it; false when the guest was too slow
 * for the cut_s.  *t_spawn: just before its start (its clock's 0 is later).
 */
static bool cut_ahead(unsigned b, const char *const *argv, unsigned cut_s, int64_t *t_spawn)
{
	kid_free(S.sims[b]);
	*t_spawn = real_ns();
	S.sims[b] = kid_spawn("rmd-sim vcan2 (bus_power)", argv, NULL, SIM_FIFO_PRIO);
	kid_wait_output_held(S.sims[b], ": ready", READY_MS, service, &S.sl_other);
	/*
	 * Its motors were silent while it restarted: enabled on, or lost and
	 * back (missed_replies_lost periods later), enabled again
	 */
	enable_all();
	run_for((int)(2 * S.cfg.safety.missed_replies_lost * 1000 / S.cfg.loop.rate_hz));
	enable_all();
	return real_ns() < *t_spawn + (int64_t)(cut_s - 1) * NS_PER_S;
}

static void test_system_no_ack(void **state)
{
	const unsigned b = 2, mot[2] = { 6, 7 };
	char fault[48], begins[96], ends[96];
	const char *argv[] = { S.rmdsim, "--config", S.cfgpath, "--can", iface(b),
			       "--seed", "3",	     "--fault", fault,	 NULL };
	unsigned cut_s = CUT_S, reports = 0;
	int64_t t_spawn, t_off, t_report, t_back, bound;
	double period_ms, stall = -1;

	(void)state;
	system_begin();
	assert_string_equal(S.cfg.motors[mot[0]].name, "c1");
	assert_string_equal(S.cfg.motors[mot[1]].name, "c2");
	rmdd_up_and_enabled();
	for (;;) {
		bool driven = true;
		const char *why;

		if (cut_s > 8 * CUT_S) {
			print_message("busy machine: the motors were not enabled again %u s after "
				      "rmd-sim restarted, four times -- not judged, the e-stop "
				      "cannot be judged on this machine now\n",
				      cut_s / 2);
			return;
		}
		snprintf(fault, sizeof(fault), "bus_power:%u:%u", cut_s, cut_s + CUT_LEN_S);
		snprintf(begins, sizeof(begins), "fault \"%s\" begins", fault);
		snprintf(ends, sizeof(ends), "fault \"%s\" ends", fault);
		if (!cut_ahead(b, argv, cut_s, &t_spawn)) {
			print_message("busy machine: the motors were enabled again only %.1f s "
				      "after rmd-sim restarted, past its cut at %u s: again with "
				      "the cut at %u s\n",
				      ms_of(real_ns() - t_spawn) / 1000.0, cut_s, cut_s * 2);
			cut_s *= 2;
			continue;
		}
		memset(S.seen_no_ack, 0, sizeof(S.seen_no_ack));
		memset(S.seen_lost, 0, sizeof(S.seen_lost));
		sleepers_mark();
		/* the cut, as rmd-sim says it (its clock's 0 is some time after t_spawn) */
		kid_wait_output_held(S.sims[b], begins, (int)(cut_s + 30) * 1000, service,
				     &S.sl_other);
		t_off = real_ns();
		/* rmdd drove them as their power went: else the verdict below says nothing */
		sync_log();
		for (unsigned k = 0; k < 2; k++)
			driven &= last_move(mot[k], t_off - 300 * NS_PER_MS, t_off) != NULL;
		if (driven)
			break;
		/* the guest stalled the loop or rmd-sim long enough to take them out of ENABLED */
		why = disable_explained();
		if (!why)
			fail_msg("c1 and c2 not driven when rmd-sim cut their power (lifecycles "
				 "%s; no stall explains it)",
				 lc_list());
		if (pace() >= MAX_PACE) {
			/* the slowest pace too: the machine's, said so (README "Tests") */
			print_message("busy machine: c1 and c2 were not driven when their power "
				      "went (%s: %s), at the slowest pace too -- not judged, the "
				      "e-stop cannot be judged on this machine now\n",
				      lc_list(), why);
			return;
		}
		print_message("busy machine: c1 and c2 were not driven when their power went "
			      "(%s: %s): again at pace %u\n",
			      lc_list(), why, pace() * 2);
		kid_wait_output_held(S.sims[b], ends, (CUT_LEN_S + 30) * 1000, service,
				     &S.sl_other);
		rmdd_restart_at(pace() * 2);
	}
	/* the adapter's report, from the cut until just before power returns */
	period_ms = 1000.0 / S.cfg.loop.rate_hz;
	t_back = t_off + CUT_LEN_S * NS_PER_S;
	sleepers_mark();
	t_report = real_ns();
	while (real_ns() < t_back - 300 * NS_PER_MS) {
		no_ack_report(b);
		reports++;
		run_for(ACK_EVERY_MS);
		/* the guest's worst delay at the loop's priority while rmdd took it in */
		if (stall < 0 && real_ns() > t_report + (int64_t)(4 * period_ms) * NS_PER_MS)
			stall = stall_rt_ms();
	}
	/* power returns: each motor boots, answers a re-probe, is armed, and runs again */
	kid_wait_output_held(S.sims[b], ends, (CUT_LEN_S + 30) * 1000, service, &S.sl_other);
	t_back = real_ns();
	enable_all();
	run_for(200);
	sync_log();
	bound = t_report + (int64_t)((2 * period_ms + stall) * NS_PER_MS);
	print_message("e-stop: the adapter's report %.1f ms after rmd-sim's cut, %u of them; "
		      "judged from %.1f ms after the first (2 periods + %.1f ms the guest held "
		      "the loop's priority off)\n",
		      ms_of(t_report - t_off), reports, ms_of(bound - t_report), stall);
	for (unsigned k = 0; k < 2; k++) {
		unsigned i = mot[k], early = 0, after = 0;
		const struct cframe *echo = first_frame(0, b, rep_id(i), 0xB3, t_back, T_END);
		const struct cframe *last = last_move(i, t_off - 300 * NS_PER_MS, t_back);

		if (!echo)
			fail_msg("%s: no 0xB3 echo after power returned; its frames:\n%s",
				 S.cfg.motors[i].name, motor_frames(i, t_off));
		for (size_t n = 0; n < S.log.nframes; n++) {
			const struct cframe *f = &S.log.frames[n];

			if (!moves_motor(f, i) || f->t_ns < bound)
				continue;
			if (f->t_ns < echo->t_ns) {
				early++;
				print_message("%s: 0x%03X #%02X %.1f ms after the first report, "
					      "%.1f ms before its 0xB3 echo\n",
					      S.cfg.motors[i].name, f->id, f->data[0],
					      ms_of(f->t_ns - t_report),
					      ms_of(echo->t_ns - f->t_ns));
			} else {
				after++;
			}
		}
		print_message("e-stop: %s: last motion frame before power returned %.1f ms after "
			      "the first report; 0xB3 echoed %.0f ms after power returned, %u "
			      "motion frames after it\n",
			      S.cfg.motors[i].name, last ? ms_of(last->t_ns - t_report) : -1.0,
			      ms_of(echo->t_ns - t_back), after);
		if (early)
			fail_msg("%s: %u motion frames after nobody acknowledged, before its 0xB3 "
				 "echo; its frames:\n%s",
				 S.cfg.motors[i].name, early, motor_frames(i, t_off));
		if (!after)
			fail_msg("%s: never driven again after power returned",
				 S.cfg.motors[i].name);
		if (!S.seen_lost[i])
			fail_msg("%s: never LOST", S.cfg.motors[i].name);
	}
	if (!strstr(S.rmdd_kid->out, "vcan2: no node acknowledges") ||
	    !strstr(S.rmdd_kid->out, "vcan2: the frames it still held are dropped"))
		fail_msg("rmdd did not log the bus nobody acknowledges, or its restart:\n%s",
			 kid_tail(S.rmdd_kid));
	if (!S.seen_no_ack[b])
		fail_msg("health_t never showed %s BUS_NO_ACK", iface(b));
}

int main(void)
{
	const struct CMUnitTest tests[] = {
		cmocka_unit_test(test_system_no_ack),
	};

	return vsys_main("vcan_estop", tests, sizeof(tests) / sizeof(tests[0]));
}
