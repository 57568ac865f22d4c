/* SPDX-License-Identifier: MIT */
/*
 * The rig of the SocketCAN system suites (tests/system/test_vcan_*.c but
 * test_vcan_batch): every program is the built one, run as a real process
 * ($BUILD/rmd-sim, $BUILD/rmdd, $BUILD/rmdctl, candump from can-utils), and
 * the suite is the controller (LCM, generated rmd_command_t).  The system's
 * fixture: rmd-sim on each bus of tests/data/vcan/system.yaml (8 motors on
 * vcan0..vcan2), candump on all of them (harness/canlog.h), LCM, and rmdd
 * on that file; the controller's commands and the event loop (service());
 * frame queries on candump's log; rmdd started, enabled, stopped.
 *
 * Time: candump -L stamps frames with the kernel's receive time
 * (CLOCK_REALTIME), so the suites take their own reference times from the
 * same clock.  candump's log is read as it grows; a marker frame (no motor
 * or rmdd listens to it) sent on every bus tells when the log has caught
 * up with "now".
 *
 * A busy machine (issue 10): the emulated guest loses the host's CPUs for
 * milliseconds to seconds when the host is loaded, and then everything in it
 * runs late.  A test fails only for wrong behaviour: each time bound is
 * judged against what this run achieved, measured in the run itself -- the
 * loop's own cycle count, skipped ticks, wake-up and cycle times (health_t),
 * and the scheduling delay of reference sleepers in the guest
 * (harness/sleeper.h: one at rmd-sim's priority, one at the loop's, one at
 * normal priority like LCM and the bridge).  Where the guest cannot support
 * a check at all (the loop cannot run its configured rate), the test runs
 * it again at a slower pace (rmdd restarted with every time of its
 * configuration 2, 4 or 8 times longer: rate, status polls, command
 * timeout, comm-loss) and says so in a line that starts "busy machine:".
 *
 * Run a suite with (tests/vm/README.md), e.g. test_vcan_system:
 *   make BUILD=build/vsys build/vsys/tests/system/test_vcan_system build/vsys/rmdd \
 *        build/vsys/rmd-sim build/vsys/rmdctl build/vsys/sine_controller
 *   BUILD=build/vsys tests/vm/vm-run --vcan 3 --timeout 900 -- \
 *        build/vsys/tests/system/test_vcan_system
 * (RMD_VSYS_KEEP=DIR keeps candump's log and rmdd's configuration in DIR.)
 * Without AF_CAN every test is skipped after one loud line.  Nothing
 * sleeps to wait for a result: every wait polls until a deadline, and
 * every child is killed in the teardown (and by PR_SET_PDEATHSIG).
 *
 * The names are the suites' own (they were one file): one state S,
 * service(), controller(), first_frame() and the rest, with no prefix.
 */
#ifndef RMD_TESTS_VSYS_H
#define RMD_TESTS_VSYS_H

#include <stdbool.h>
#include <stddef.h>
#include <stdint.h>

#include <lcm/lcm.h>

#include "harness/canlog.h"
#include "harness/evloop.h"
#include "harness/gap.h"
#include "harness/proc.h"
#include "harness/sleeper.h"
#include "rmd/config.h"
#include "rmd/rmd_health_t.h"
#include "rmd/rmd_state_t.h"

struct CMUnitTest;

#define NS_PER_MS INT64_C(1000000)
#define NS_PER_S INT64_C(1000000000)

/*
 * Margins.  The guest runs under TCG, about 8x slower than the host
 * (tests/vm/README.md); starting a program from the 9p share takes 0.1-1 s.
 * READY_MS and ENABLE_MS are waits, not bounds: with the host's CPUs busy
 * the guest runs 10-20x slower still (measured: rmdd's loop at 9 Hz of its
 * 100 Hz, a cycle of 370 ms, no "running" 20 s after the start).
 */
#define READY_MS 60000	/* rmd-sim, candump, rmdd up (rmdd: bring-up of 8 motors) */
#define ENABLE_MS 30000 /* enable -> every motor ENABLED in state_t */
#define TOOL_MS 30000	/* one rmdctl run */
#define EXIT_MS 15000	/* SIGTERM -> rmdd gone */
/*
 * The simulated motors are the hardware: a real motor answers whatever the
 * host's load.  rmd-sim (event-driven, never spinning) runs at SCHED_FIFO
 * above rmdd's loop (loop.rt_priority 40), so the guest's two emulated
 * CPUs, shared with rmdd, candump and this test, do not starve it.
 */
#define SIM_FIFO_PRIO 45
/*
 * The slower paces the rate test retries at, when the guest stalled rmdd's
 * loop for whole periods (see test_system_rate): every time of the
 * configuration 2, 4, then MAX_PACE times longer (write_config()), and the
 * test's own settle and measurement windows with them.
 */
#define MAX_PACE 8
#define CTL_PERIOD_MS 10 /* the controller publishes at 100 Hz */
#define NBUS_MAX CANLOG_BUSES

#define SETPOINT_RAD 0.2
#define INTRUDER_OFF_RAD 0.1 /* issue 13: the second controller's setpoints, beside the owner's */

#define T_END CANLOG_T_END

struct health {
	int64_t utime;
	int64_t cycles, overruns, plan_misses;
	double wake_avg_us, wake_p99_us, wake_max_us, cycle_max_us;
	int8_t watchdog;
	int64_t safe_action_events;
	int64_t accepted, rejected;
	bool owned;
	int64_t owner, intruder, rejected_owner, takeovers;
};

/* issue 13, fine position: what the state_t of a measurement window said, per motor */
struct fine_stats {
	unsigned states;      /* state_t with a position from a 0x92 answer */
	unsigned enabled;     /* of those, with the motor ENABLED */
	unsigned off_lsb;     /* positions not a whole number of 0.01 deg */
	unsigned fine;	      /* positions not a whole degree */
	unsigned new_times;   /* position_rx_time_ns that changed */
	int64_t last_time_ns; /* the previous position_rx_time_ns */
	int64_t pos_age_max;  /* utime - position_rx_time_ns, ns */
	int64_t vel_age_max;  /* utime - rx_time_ns, ns */
	double worst_off;     /* largest distance to 0.01 deg steps, in centidegrees */
};

/* The suite's state: its programs and files, candump's log, LCM, the controller. */
struct vsys {
	bool have_can;
	char build[512];
	char rmdd[600], rmdsim[600], rmdctl[600];
	char dir[128];	   /* /dev/shm/rmd-vsys-PID */
	char cfgpath[192]; /* the configuration rmdd runs */
	char logpath[192]; /* candump's log */
	struct rmd_config cfg;
	unsigned nbus;

	struct kid *sims[NBUS_MAX], *candump, *rmdd_kid;

	/* candump's log; markers and the test's own requests */
	struct canlog log;

	/* LCM */
	char url[96];
	lcm_t *lcm;
	rmd_state_t_subscription_t *sub_state;
	rmd_health_t_subscription_t *sub_health;
	uint64_t n_state, n_health;
	int16_t st_count;
	int64_t st_utime; /* state_t.utime: the loop's cycle time, rmdd's CLOCK_MONOTONIC */
	int64_t st_cycle;
	int8_t lc[RMD_MAX_MOTORS];
	bool seen_lost[RMD_MAX_MOTORS]; /* a state_t showed the motor LOST */
	bool fine_on;			/* fine[] counts (test_system_fine_position) */
	int8_t bus_state[NBUS_MAX];	/* health_t.bus[].state, the newest */
	bool seen_no_ack[NBUS_MAX];	/* a health_t showed the bus BUS_NO_ACK */
	struct fine_stats fine[RMD_MAX_MOTORS];
	struct health h;

	/* the controller */
	struct ctl_clock ctl; /* publishing at CTL_PERIOD_MS while on */
	bool ctl_enable;
	int64_t seq;
	int64_t last_pub_real; /* CLOCK_REALTIME just before the last publish */
	uint64_t n_pub;
	/* the owner's (ctl_id's) commands: how long rmdd heard nothing of it (harness/gap.h) */
	struct gap own;

	unsigned edge_toggles; /* enable = 0 sent to get enable = 1 taken */
	/*
	 * issue 13: the controller's id (command_t.controller, 0 unless a test
	 * sets it), a second controller publishing beside it (intruder_id, 0:
	 * none) at SETPOINT_RAD + INTRUDER_OFF_RAD, takeover on its next
	 * message, and a sine added to every setpoint (amplitude 0: none).
	 */
	int64_t ctl_id, intruder_id;
	bool intruder_takeover;
	bool unjudged; /* owner_alone(): its last window was not judged (busy machine) */
	double sine_amp_rad;
	int64_t sine_t0;
	const char *motor_extra; /* appended to every motor's map by write_config() */

	/* keepalive(): a read to one motor every KEEPALIVE_MS */
	int ka_bus;
	unsigned ka_id;
	int64_t ka_next;

	/*
	 * Reference sleepers: the scheduling delay the guest imposed in this
	 * run, at rmd-sim's priority, at the loop's, and at normal priority
	 * (LCM's receive thread and the bridge).
	 */
	struct sleeper sl_sim, sl_loop, sl_other;
	unsigned pace; /* 1: the file's times; P: P times slower (write_config()) */
	unsigned base_rate_hz, base_timeout_ms, base_loss_ms; /* the file's */
};

extern struct vsys S;

/* ns in milliseconds. */
double ms_of(int64_t ns);

/* Begin a measurement window of every reference sleeper. */
void sleepers_mark(void);

/* The pace: 1, or how many times the file's times rmdd runs at (write_config()). */
unsigned pace(void);

/*
 * Start the reference sleepers (once): at rmd-sim's priority, at the loop's
 * (loop_prio), and at normal priority.
 */
void sleepers_up(int loop_prio);

/* The owner's longest silence since the mark, ms: the widest gap between two of its commands. */
double own_gap_ms(void);

/* The worst delay since the mark at the loop's or at rmd-sim's priority, ms. */
double stall_rt_ms(void);

/*
 * Why ENABLED motors may leave that state, since the sleepers' mark,
 * without rmdd being wrong (issue 10): the guest held rmdd's loop or
 * rmd-sim off for about the motors' comm-loss time (the motors' own 0xB3
 * protection trips: the gap a motor hears is a period plus the stall),
 * held rmd-sim off while the loop ran for missed_replies_lost periods
 * (rmdd takes its motors as lost, rightly), or held the controller, this
 * test at normal priority, off for the command timeout (rmdd's watchdog
 * trips rightly).  NULL when the sleepers saw
 * neither, else the reason, for a "busy machine:" line.
 */
const char *disable_explained(void);

/* Bus b's interface (vcan0, ...). */
const char *iface(unsigned b);

/*
 * The first frame of the configured safe action (include/rmd/loop.h): V3
 * §2.15 0x80 output off, §2.16 0x81 stop and hold, §2.18 0xA2 speed 0.
 */
uint8_t safe_cmd(enum rmd_safe_action a);

/*
 * Wait at most max_ms for anything to happen, and handle it: LCM messages,
 * children's output, the controller's next command, candump's log.
 */
void service(int max_ms);

/* Let everything run for ms milliseconds (a measurement window, not a wait for a result). */
void run_for(int ms);

/* The controller from now on: publishing or not (at CTL_PERIOD_MS), with enable or not. */
void controller(bool on, bool enable);

/* Wait until candump's log holds everything sent on every bus before this call. */
void sync_log(void);

/* Run argv[0] (a path) to its end, at most TOOL_MS; its output and status in *r. */
void run_tool(struct run *r, const char *const *argv);

/* Fails the test when path is not an executable (build it). */
void need_exec(const char *path);

/*
 * tests/data/vcan/system.yaml with URL_PLACEHOLDER replaced, into
 * S.cfgpath; then load it.  At a slower pace (S.pace = P > 1, a busy
 * machine: see test_system_rate) every time of the file is P times longer:
 * the loop rate and each motor's status polls P times lower, the command
 * timeout and the comm-loss time P times longer.
 */
void write_config(void);

/*
 * The system's fixture, once per suite: the configuration written, the
 * reference sleepers, rmd-sim on each bus, candump, LCM; skips the test
 * without SocketCAN, fails it when an earlier test could not start them.
 */
void system_begin(void);

/* rmdd was started and has not exited. */
bool rmdd_running(void);

/*
 * rmdd started on S.cfgpath, up to its "running:" line (its bring-up
 * report printed); fails when its bring-up took a tripped motor's echo.
 */
void rmdd_start(void);

/* Every motor in lifecycle lc in the last state_t. */
bool all_lc(int8_t lc);

/* For messages: every motor's lifecycle, "a1=2 a2=2 ...". */
const char *lc_list(void);

/* The earliest (latest; how many) of the frames from index `from` on (harness/canlog.h). */
const struct cframe *first_frame(size_t from, unsigned b, unsigned id, int cmd, int64_t t0,
				 int64_t t1);

const struct cframe *last_frame(size_t from, unsigned b, unsigned id, int cmd, int64_t t0,
				int64_t t1);

unsigned count_frames(size_t from, unsigned b, unsigned id, int cmd, int64_t t0, int64_t t1);

/* Motor i's request and reply identifiers (V3 §1.1.2: 0x140 + ID, 0x240 + ID). */
unsigned req_id(unsigned i);

unsigned rep_id(unsigned i);

/* Wait (publishing as the controller is set) until every motor is in lifecycle lc. */
bool wait_all_lc(int8_t lc, int ms);

/*
 * enable_try(), and when the motors do not all get ENABLED while the guest
 * stalled a thread at the loop's or rmd-sim's priority for a period or more
 * (since the last sleepers_mark()): the machine cannot run the system at
 * this pace -- motors go LOST and trip their comm-loss protection because
 * nobody runs, not because rmdd is wrong.  Then rmdd starts again at a
 * slower pace (write_config()), said on a "busy machine:" line.
 */
double enable_all(void);

/*
 * rmdd running and every motor ENABLED: started when it is not (what its
 * start did to the motors reported), else enabled again (enable_all()).
 */
void rmdd_up_and_enabled(void);

/* For failure messages: motor i's frames in the log, times relative to t_ref. */
const char *motor_frames(unsigned i, int64_t t_ref);

/* A test's teardown: every child killed. */
int rmdctl_teardown(void **state);

/* S.dir/name holding text (a configuration of one test); its path into path. */
void config_file(const char *name, const char *text, char *path, size_t len);

/*
 * Stop rmdd and start it again at a slower pace (a busy machine): the
 * configuration is written anew with every time `pace` times longer
 * (write_config()), and every later test runs at it.
 */
void rmdd_restart_at(unsigned pace);

/*
 * A suite's main(): SIGPIPE ignored, the paths of this run, whether
 * SocketCAN and vcan0..vcan2 are here (without them every test skips,
 * after one loud "SKIP:" line), then tests[0..n-1] as the group `name`;
 * afterwards every child is killed and the run's files are removed (or
 * kept: RMD_VSYS_KEEP).
 */
int vsys_main(const char *name, const struct CMUnitTest *tests, size_t n);

#endif /* RMD_TESTS_VSYS_H */
