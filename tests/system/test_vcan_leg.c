// SPDX-License-Identifier: MIT
/*
 * The leg of examples/physics/ on real SocketCAN, in the VM (docs/physics.md
 * "The whole loop"): rmd-sim ($BUILD/rmd-sim) simulates both motors on the
 * MuJoCo model behind vcan0 from examples/physics/leg-vcan.yaml as shipped,
 * rmdd drives them there from the same file, and the same controller as on
 * the sim bus (build/leg_stand) stands the leg; this suite judges it from
 * state_t as test_physics_leg does (harness/leg.h): it holds its height,
 * and when the controller dies the watchdog's stop shows in state_t and the
 * leg falls.
 *
 * rmd-sim steps the model in real time.  Where the machine cannot (the
 * VM's emulated CPUs, TCG, run MuJoCo about 100 times slower than the host:
 * bench/physics-rtf.sh), rmd-sim says the model steps slower than real
 * time, and its world falls behind real time rather than its replies
 * (docs/physics.md "Time and rate").  Then the test runs the same file at
 * the rates such a machine holds (GUEST_LOOP_HZ, GUEST_PHYSICS_HZ: the
 * motors' MIT PD runs in the motors, so a 100 Hz loop stands the leg as
 * well), and judges it the same way; on a host with vcan (tests/vm/vm-run
 * uses it) or KVM the shipped file runs in full.
 */
#define _GNU_SOURCE
#include <limits.h>
#include <signal.h>
#include <setjmp.h>
#include <stdarg.h>
#include <stdbool.h>
#include <stddef.h>
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <unistd.h>

#include <net/if.h>
#include <sys/socket.h>

#include <linux/can.h>

#include <cmocka.h>

#include "harness/lcm_loopback.h"
#include "harness/leg.h"
#include "harness/proc.h"
#include "harness/sleeper.h"
#include "harness/suite.h"
#include "rmd/time.h"

#define START_MS 120000	 /* rmd-sim ready, rmdd running: the guest is slow */
#define VERDICT_MS 20000 /* rmdd gone: rmd-sim's word on why, within this */
#define STAND_S 2	 /* the leg holds its height over this many seconds of rmdd's cycles */
#define GUEST_LOOP_HZ 100
#define GUEST_PHYSICS_HZ 250

/* When rmdd was first seen gone, plus VERDICT_MS: *gone keeps it (0: not yet). */
static int64_t rmdd_exit_ns(int64_t *gone)
{
	if (!*gone)
		*gone = rmd_now_ns() + (int64_t)VERDICT_MS * RMD_NS_PER_MS;
	return *gone;
}

static char rmdd_bin[PATH_MAX], rmdctl_bin[PATH_MAX], sim_bin[PATH_MAX], leg_bin[PATH_MAX],
	config[PATH_MAX + 64], guest[PATH_MAX + 64], dir[PATH_MAX] = "/tmp/test_vcan_leg.XXXXXX";
static bool multicast, have_module;
static const char *no_can;

/* At the guest's rates: a thread of rmdd's loop's class, and the rmdd it judges. */
static struct sleeper sl;
static const struct kid *guest_rmdd;

/*
 * leg_busy at the guest's rates, where rmd-sim already said it steps the
 * model slower than real time: rmdd lost a motor or counted its answers
 * late -- a machine that cannot carry the loop and the model now (the
 * stall a real-time thread saw says how busy), not a judgement of the leg.
 * What the leg does once standing is judged in full.
 */
static bool guest_busy(char *why, size_t size)
{
	const char *out = guest_rmdd ? guest_rmdd->out : "";

	if (!strstr(out, "): lost (") && !strstr(out, "after rmdd gave it up"))
		return false;
	snprintf(why, size,
		 "rmd-sim behind real time, rmdd %s, the guest holding a real-time thread off up "
		 "to %.1f ms (the loop's period %d ms): the leg cannot be judged on this machine "
		 "now",
		 strstr(out, "): lost (") ? "lost a motor" : "counted answers late",
		 sleeper_stall_ms(&sl), 1000 / GUEST_LOOP_HZ);
	return true;
}

static int group_setup(void **state)
{
	const char *src = getenv("RMD_SRCDIR");
	int fd;

	(void)state;
	if (lcm_tools_setup("test_vcan_leg", rmdd_bin, rmdctl_bin, dir, &multicast) < 0 ||
	    find_prog(sim_bin, sizeof(sim_bin), "RMD_SIM", "rmd-sim") < 0 ||
	    find_prog(leg_bin, sizeof(leg_bin), "LEG_STAND", "leg_stand") < 0)
		return -1;
	have_module = physics_module_found(rmdd_bin, "test_vcan_leg");
	fd = socket(PF_CAN, SOCK_RAW | SOCK_CLOEXEC, CAN_RAW);
	if (fd < 0)
		no_can = "no SocketCAN here (make test runs this suite in the VM)";
	else if (close(fd), !if_nametoindex("vcan0"))
		no_can = "no vcan0 here (tests/vm/vm-run --vcan 1 creates it)";
	snprintf(config, sizeof(config), "%s/examples/physics/leg-vcan.yaml",
		 src && src[0] ? src : ".");
	return access(config, R_OK);
}

/* The one `from` in text (size bytes) replaced by `to`; fails when `from` is not there once. */
static void replace_once(char *text, size_t size, const char *from, const char *to)
{
	static char was[16384];
	const char *at = strstr(text, from);

	if (!at || strstr(at + 1, from))
		fail_msg("leg-vcan.yaml: want \"%s\" once in it", from);
	snprintf(was, sizeof(was), "%s", text);
	snprintf(text + (at - text), size - (size_t)(at - text), "%s%s", to,
		 was + (at - text) + strlen(from));
}

/*
 * The shipped file at the rates a machine that cannot step the model in
 * real time holds: the loop's and the physics' rate_hz, the model by its
 * whole path (the file moves to the test's directory).  Into guest.
 */
static void guest_config(void)
{
	static char text[16384];
	char leg[PATH_MAX + 16], model[PATH_MAX], to[PATH_MAX + 64];
	const char *slash = strrchr(config, '/');
	FILE *f;

	if (!file_text(config, text, sizeof(text))[0])
		fail_msg("%s: unreadable", config);
	snprintf(leg, sizeof(leg), "%.*s/leg.xml", (int)(slash - config), config);
	if (!realpath(leg, model))
		fail_msg("%s: not found", leg);
	snprintf(to, sizeof(to), "loop:\n  rate_hz: %d\n", GUEST_LOOP_HZ);
	replace_once(text, sizeof(text), "loop:\n  rate_hz: 1000\n", to);
	snprintf(to, sizeof(to), "    model: %s\n", model);
	replace_once(text, sizeof(text), "    model: leg.xml\n", to);
	snprintf(to, sizeof(to), "\n    rate_hz: %d\n", GUEST_PHYSICS_HZ);
	replace_once(text, sizeof(text), "\n    rate_hz: 1000\n", to);
	snprintf(guest, sizeof(guest), "%s/leg-guest.yaml", dir);
	f = fopen(guest, "w");
	assert_non_null(f);
	fputs(text, f);
	assert_int_equal(fclose(f), 0);
}

/*
 * rmd-sim and rmdd on the file `cfg`, rmdd at rate_hz; the leg stands and
 * falls (harness/leg.h).  With `bail`, false when rmd-sim says it steps
 * the model slower than real time before rmdd runs (its line into why).
 */
static bool leg_on(const char *cfg, unsigned rate_hz, bool bail, char *why, size_t why_size)
{
	char url[128];
	const char *sim_argv[] = { sim_bin, "--config", cfg, NULL };
	const char *argv[] = { rmdd_bin, "--config", cfg, "--lcm-url", url, NULL };
	struct kid *sim, *rmdd;
	int64_t end, rmdd_gone = 0;

	lcm_test_url(url, sizeof(url), 44900, 10, 0);
	sim = kid_spawn("rmd-sim", sim_argv, NULL, 0);
	kid_wait_output(sim, "vcan0: ready", START_MS, NULL);
	rmdd = kid_spawn("rmdd", argv, NULL, 0);
	/* rmdd brings the motors up and runs */
	end = rmd_now_ns() + (int64_t)START_MS * RMD_NS_PER_MS;
	while (!strstr(rmdd->out, "rmdd: running:")) {
		kid_read(sim);
		kid_read(rmdd);
		if (bail && strstr(sim->out, "slower than real time")) {
			line_with(sim->out, "slower than real time", why, why_size);
			kid_free(rmdd);
			kid_free(sim);
			return false;
		}
		/* an rmdd that found no motor: rmd-sim may say why once it gets to its frames */
		if ((kid_poll_exit(rmdd) && rmd_now_ns() > rmdd_exit_ns(&rmdd_gone)) ||
		    kid_poll_exit(sim) || rmd_now_ns() > end)
			fail_msg(
				"rmdd did not start on rmd-sim's motors (%s); rmdd:\n%s\nrmd-sim:\n%s",
				cfg, kid_tail(rmdd), kid_tail(sim));
		usleep(10000);
	}
	if (!bail) {
		guest_rmdd = rmdd;
		leg_busy = guest_busy;
		sleeper_mark(&sl);
	}
	leg_stand_and_fall(url, leg_bin, rmdd, STAND_S * rate_hz, START_MS);
	leg_busy = NULL;
	guest_rmdd = NULL;
	kid_free(rmdd);
	/* its summary: how far its world fell behind real time */
	kill(sim->pid, SIGTERM);
	if (kid_wait_exit(sim, START_MS, NULL) != 0)
		fail_msg("rmd-sim did not stop cleanly on SIGTERM:\n%s", kid_tail(sim));
	print_message("rmd-sim: %s\n", line_with(sim->out, "stopped (", why, why_size));
	kid_free(sim);
	return true;
}

static void test_vcan_stands_and_falls(void **state)
{
	char why[512];

	(void)state;
	if (no_can) {
		print_message("SKIP: %s\n", no_can);
		skip();
	}
	if (!multicast || !have_module)
		skip();
	if (leg_on(config, 1000, true, why, sizeof(why)))
		return;
	print_message("rmd-sim on the shipped file: %s\n", why);
	guest_config();
	print_message("again at the rates this machine holds: loop %d Hz, physics %d Hz (%s)\n",
		      GUEST_LOOP_HZ, GUEST_PHYSICS_HZ, guest);
	if (!sl.started && sleeper_start(&sl, RMD_NS_PER_MS, 30) < 0)
		fail_msg("the reference sleeper did not start");
	leg_on(guest, GUEST_LOOP_HZ, false, why, sizeof(why));
}

static int group_teardown(void **state)
{
	sleeper_stop(&sl);
	return lcm_tools_teardown(state);
}

SUITE_MAIN("vcan_leg", group_setup, group_teardown,
	   {
		   cmocka_unit_test(test_vcan_stands_and_falls),
	   })
