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
 * time and the test skips, naming how late it answered; on a host with
 * vcan (tests/vm/vm-run uses it) or KVM it runs in full.
 */
#define _GNU_SOURCE
#include <limits.h>
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
#include "harness/suite.h"
#include "rmd/time.h"

#define START_MS 120000	 /* rmd-sim ready, rmdd running: the guest is slow */
#define VERDICT_MS 20000 /* rmdd gone: rmd-sim's word on why, within this */

/* When rmdd was first seen gone, plus VERDICT_MS: *gone keeps it (0: not yet). */
static int64_t rmdd_exit_ns(int64_t *gone)
{
	if (!*gone)
		*gone = rmd_now_ns() + (int64_t)VERDICT_MS * RMD_NS_PER_MS;
	return *gone;
}

static char rmdd_bin[PATH_MAX], rmdctl_bin[PATH_MAX], sim_bin[PATH_MAX], leg_bin[PATH_MAX],
	config[PATH_MAX + 64], dir[PATH_MAX] = "/tmp/test_vcan_leg.XXXXXX";
static bool multicast, have_module;
static const char *no_can;

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

static void test_vcan_stands_and_falls(void **state)
{
	char url[128];
	const char *sim_argv[] = { sim_bin, "--config", config, NULL };
	const char *argv[] = { rmdd_bin, "--config", config, "--lcm-url", url, NULL };
	struct kid *sim, *rmdd;
	int64_t end, rmdd_gone = 0;

	(void)state;
	if (no_can) {
		print_message("SKIP: %s\n", no_can);
		skip();
	}
	if (!multicast || !have_module)
		skip();
	lcm_test_url(url, sizeof(url), 44900, 10, 0);
	sim = kid_spawn("rmd-sim", sim_argv, NULL, 0);
	kid_wait_output(sim, "vcan0: ready", START_MS, NULL);
	rmdd = kid_spawn("rmdd", argv, NULL, 0);
	/* rmdd brings the motors up and runs, unless rmd-sim cannot keep real time here */
	end = rmd_now_ns() + (int64_t)START_MS * RMD_NS_PER_MS;
	while (!strstr(rmdd->out, "rmdd: running:")) {
		const char *behind = strstr(sim->out, "slower than real time");

		kid_read(sim);
		kid_read(rmdd);
		if (behind) {
			char line[512];

			print_message("rmd-sim: %s\n", line_with(sim->out, "slower than real time",
								 line, sizeof(line)));
			print_message("SKIP: rmd-sim cannot step the model in real time here\n");
			kid_free(rmdd);
			kid_free(sim);
			skip();
		}
		/* an rmdd that found no motor: rmd-sim may say why once it gets to its frames */
		if ((kid_poll_exit(rmdd) && rmd_now_ns() > rmdd_exit_ns(&rmdd_gone)) ||
		    kid_poll_exit(sim) || rmd_now_ns() > end)
			fail_msg("rmdd did not start on rmd-sim's motors; rmdd:\n%s\nrmd-sim:\n%s",
				 kid_tail(rmdd), kid_tail(sim));
		usleep(10000);
	}
	leg_stand_and_fall(url, leg_bin, rmdd, 2000, START_MS);
	kid_free(rmdd);
	kid_free(sim);
}

SUITE_MAIN("vcan_leg", group_setup, lcm_tools_teardown,
	   {
		   cmocka_unit_test(test_vcan_stands_and_falls),
	   })
