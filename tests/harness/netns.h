/* SPDX-License-Identifier: MIT */
/*
 * Separate machines on one host, for the suites that test rmdd across a
 * network (issue 30): each "host" (robot PC A, B, a controller C, a
 * spoofer D ...) is a network namespace with loopback up and one interface,
 * eth0, whose veth peer is a port of a bridge living in a namespace of its
 * own, so the host's network is never touched.  Each host has an address
 * of 10.77.0.0/24 and routes multicast (224.0.0.0/4) out of eth0: LCM udpm
 * with ttl=1 crosses the bridge.  (On this kernel a TTL 0 datagram still
 * crosses a veth pair: keep tests apart by multicast group and port, never
 * by TTL.)
 *
 * Namespaces are named rmdt-PID-HOST (rmdt-PID-br for the bridge), unique
 * to the test process.  netns_net_down() removes them all; it runs at exit
 * too, and netns_net_up() first removes the namespaces of test processes
 * that died without it (SIGKILL), so `ip netns list` keeps nothing.
 * Needs root, ip (iproute2) and, for netns_loss(), nft (nftables).  Non-rt.
 */
#ifndef RMD_TESTS_NETNS_H
#define RMD_TESTS_NETNS_H

#include <stdbool.h>
#include <stddef.h>

struct kid;

#define NETNS_HOSTS 6
#define NETNS_NAME_LEN 32

struct netns_net {
	unsigned n;				/* hosts; 0: not up */
	char bridge[NETNS_NAME_LEN];		/* the bridge's namespace */
	char name[NETNS_HOSTS][NETNS_NAME_LEN]; /* each host's namespace */
	char addr[NETNS_HOSTS][16];		/* each host's eth0 address, 10.77.0.(i + 1) */
};

/*
 * NULL when this process can build namespaces (root, ip, nft); else why
 * not, in words for a skip line.
 */
const char *netns_unavailable(void);

/*
 * Bring up n hosts (at most NETNS_HOSTS) named by hosts[] (short words,
 * e.g. "a", "b", "c": the tail of each namespace's name) on one bridge.
 * 0, or -1 after one line on stderr naming the command that failed (what
 * was made so far is removed).
 */
int netns_net_up(struct netns_net *net, const char *const *hosts, unsigned n);

/* Take every namespace of net down (this thread back in its own first); a zeroed net is fine. */
void netns_net_down(struct netns_net *net);

/* Remove the rmdt-PID-* namespaces of processes that no longer run; how many. */
unsigned netns_sweep(void);

/*
 * The calling thread into host i's namespace: sockets it opens from now on
 * (an lcm_t and its subscriptions) belong to that host and stay there.
 * 0, or -errno.
 */
int netns_enter(const struct netns_net *net, unsigned i);

/* The calling thread back into the namespace it started in (0, or -errno). */
int netns_leave(void);

/*
 * kid_spawn() of argv (argv[0] a path or a name in PATH) inside host i's
 * namespace (`ip netns exec`: the pid is the program's own).
 */
struct kid *netns_kid_spawn(const struct netns_net *net, unsigned i, const char *name,
			    const char *const *argv, const char *out_path);

/*
 * Drop pct % (0..100) of the IP packets that reach host i on its eth0, at
 * random (nftables: numgen random mod 100 < pct drop); 0 removes the loss.
 * 0, or -1.
 */
int netns_loss(const struct netns_net *net, unsigned i, unsigned pct);

/* The names in `ip netns list` that begin with prefix, into out (at most size); their count. */
unsigned netns_listed(const char *prefix, char *out, size_t size);

#endif /* RMD_TESTS_NETNS_H */
