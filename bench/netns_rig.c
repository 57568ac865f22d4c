// SPDX-License-Identifier: MIT
/*
 * Separate machines for the benchmarks (bench/robot-delay.sh): the
 * namespaces, bridge and multicast routes of tests/harness/netns.h, held up
 * while a script runs its programs in them (`ip netns exec NAMESPACE ...`).
 *
 *   netns_rig HOST...
 *
 * Prints one line a host, "HOST NAMESPACE ADDRESS", then "up", and holds
 * the network until its stdin ends or SIGTERM/SIGINT/SIGHUP; then takes it
 * all down and exits 0 (1 when it could not bring it up).  Non-rt; root.
 */
#define _GNU_SOURCE
#include <signal.h>
#include <stdio.h>
#include <string.h>
#include <unistd.h>

#include "harness/netns.h"

static volatile sig_atomic_t stop;

static void on_signal(int sig)
{
	(void)sig;
	stop = 1;
}

int main(int argc, char **argv)
{
	const struct sigaction sa = { .sa_handler = on_signal };
	struct netns_net net;
	const char *why = netns_unavailable();
	char c;

	if (argc < 2 || argc - 1 > NETNS_HOSTS || !strcmp(argv[1], "-h")) {
		fprintf(stderr, "usage: netns_rig HOST... (1..%d hosts)\n", NETNS_HOSTS);
		return 2;
	}
	if (why) {
		fprintf(stderr, "netns_rig: %s\n", why);
		return 1;
	}
	/* no SA_RESTART: a signal ends the read() below */
	sigaction(SIGTERM, &sa, NULL);
	sigaction(SIGINT, &sa, NULL);
	sigaction(SIGHUP, &sa, NULL);
	if (netns_net_up(&net, (const char *const *)argv + 1, (unsigned)argc - 1) < 0)
		return 1;
	for (unsigned i = 0; i < net.n; i++)
		printf("%s %s %s\n", argv[i + 1], net.name[i], net.addr[i]);
	printf("up\n");
	fflush(stdout);
	while (!stop && read(STDIN_FILENO, &c, 1) > 0)
		;
	netns_net_down(&net);
	return 0;
}
