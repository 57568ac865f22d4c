// SPDX-License-Identifier: MIT
/* Network namespaces as separate machines (netns.h). */
#define _GNU_SOURCE
#include <dirent.h>
#include <errno.h>
#include <fcntl.h>
#include <sched.h>
#include <signal.h>
#include <stdarg.h>
#include <stdbool.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <unistd.h>

#include <sys/wait.h>

#include "harness/netns.h"
#include "harness/proc.h"

#define PREFIX "rmdt-"
#define NETNS_DIR "/run/netns"
#define SUBNET "10.77.0"

static int home_fd = -1;	  /* /proc/self/ns/net of the process at its first netns_net_up() */
static struct netns_net *live[4]; /* what netns_net_down() at exit takes down */

/* sh -c of the formatted command: 0 when it exited 0, else -1 after a line naming it. */
__attribute__((format(printf, 1, 2))) static int cmd(const char *fmt, ...)
{
	char line[1024];
	va_list ap;
	int st;

	va_start(ap, fmt);
	vsnprintf(line, sizeof(line), fmt, ap);
	va_end(ap);
	st = system(line);
	if (st == 0)
		return 0;
	fprintf(stderr, "netns: `%s`: %s %d\n", line, st < 0 ? "cannot run" : "exit",
		st < 0 ? errno : WEXITSTATUS(st));
	return -1;
}

static bool in_path(const char *prog)
{
	char line[128];

	snprintf(line, sizeof(line), "command -v %s >/dev/null 2>&1", prog);
	return system(line) == 0;
}

const char *netns_unavailable(void)
{
	if (geteuid() != 0)
		return "network namespaces need root";
	if (!in_path("ip"))
		return "no ip (iproute2) in PATH";
	if (!in_path("nft"))
		return "no nft (nftables) in PATH: make deps";
	return NULL;
}

unsigned netns_sweep(void)
{
	DIR *d = opendir(NETNS_DIR);
	struct dirent *e;
	unsigned n = 0;

	if (!d)
		return 0;
	while ((e = readdir(d))) {
		char *end;
		long pid;

		if (strncmp(e->d_name, PREFIX, strlen(PREFIX)) != 0)
			continue;
		pid = strtol(e->d_name + strlen(PREFIX), &end, 10);
		if (end == e->d_name + strlen(PREFIX) || *end != '-' || pid <= 0)
			continue;
		if (kill((pid_t)pid, 0) == 0 || errno != ESRCH)
			continue;
		if (cmd("ip netns delete %s", e->d_name) == 0)
			n++;
	}
	closedir(d);
	return n;
}

static void down_at_exit(void)
{
	for (unsigned i = 0; i < sizeof(live) / sizeof(live[0]); i++)
		netns_net_down(live[i]);
}

static void remember(struct netns_net *net)
{
	static bool at_exit;
	unsigned i;

	if (!at_exit)
		at_exit = atexit(down_at_exit) == 0;
	for (i = 0; i < sizeof(live) / sizeof(live[0]); i++)
		if (live[i] == net || !live[i])
			break;
	if (i < sizeof(live) / sizeof(live[0]))
		live[i] = net;
}

static void forget(const struct netns_net *net)
{
	for (unsigned i = 0; i < sizeof(live) / sizeof(live[0]); i++)
		if (live[i] == net)
			live[i] = NULL;
}

/* Host i: its namespace, its veth pair to the bridge (vI there, eth0 here), address, routes. */
static int host_up(const struct netns_net *net, unsigned i)
{
	const char *ns = net->name[i];

	if (cmd("ip netns add %s", ns) < 0 || cmd("ip -n %s link set lo up", ns) < 0 ||
	    cmd("ip -n %s link add v%u type veth peer name eth0 netns %s", net->bridge, i, ns) <
		    0 ||
	    cmd("ip -n %s link set v%u master br0 up", net->bridge, i) < 0 ||
	    cmd("ip -n %s addr add %s/24 dev eth0", ns, net->addr[i]) < 0 ||
	    cmd("ip -n %s link set eth0 up multicast on", ns) < 0 ||
	    cmd("ip -n %s route add 224.0.0.0/4 dev eth0", ns) < 0)
		return -1;
	return 0;
}

int netns_net_up(struct netns_net *net, const char *const *hosts, unsigned n)
{
	long pid = (long)getpid();

	memset(net, 0, sizeof(*net));
	if (n == 0 || n > NETNS_HOSTS) {
		fprintf(stderr, "netns: %u hosts (1..%d)\n", n, NETNS_HOSTS);
		return -1;
	}
	if (home_fd < 0)
		home_fd = open("/proc/self/ns/net", O_RDONLY | O_CLOEXEC);
	if (home_fd < 0) {
		fprintf(stderr, "netns: /proc/self/ns/net: %s\n", strerror(errno));
		return -1;
	}
	netns_sweep();
	snprintf(net->bridge, sizeof(net->bridge), PREFIX "%ld-br", pid);
	for (unsigned i = 0; i < n; i++) {
		snprintf(net->name[i], sizeof(net->name[i]), PREFIX "%ld-%.8s", pid, hosts[i]);
		snprintf(net->addr[i], sizeof(net->addr[i]), SUBNET ".%u", i + 1);
	}
	remember(net);
	/* The bridge floods multicast to every port: no IGMP snooping, no querier needed. */
	if (cmd("ip netns add %s", net->bridge) < 0 ||
	    cmd("ip -n %s link add br0 type bridge mcast_snooping 0", net->bridge) < 0 ||
	    cmd("ip -n %s link set br0 up", net->bridge) < 0)
		goto err_down;
	for (unsigned i = 0; i < n; i++) {
		net->n = i + 1; /* what netns_net_down() removes */
		if (host_up(net, i) < 0)
			goto err_down;
	}
	return 0;

err_down:
	netns_net_down(net);
	return -1;
}

void netns_net_down(struct netns_net *net)
{
	if (!net || !net->bridge[0])
		return;
	netns_leave();
	for (unsigned i = 0; i < net->n; i++)
		(void)cmd("[ ! -e " NETNS_DIR "/%s ] || ip netns delete %s", net->name[i],
			  net->name[i]);
	(void)cmd("[ ! -e " NETNS_DIR "/%s ] || ip netns delete %s", net->bridge, net->bridge);
	forget(net);
	memset(net, 0, sizeof(*net));
}

int netns_enter(const struct netns_net *net, unsigned i)
{
	char path[64 + NETNS_NAME_LEN];
	int fd, r = 0;

	if (i >= net->n)
		return -EINVAL;
	snprintf(path, sizeof(path), NETNS_DIR "/%s", net->name[i]);
	fd = open(path, O_RDONLY | O_CLOEXEC);
	if (fd < 0)
		return -errno;
	if (setns(fd, CLONE_NEWNET) < 0)
		r = -errno;
	close(fd);
	return r;
}

int netns_leave(void)
{
	if (home_fd < 0)
		return 0;
	return setns(home_fd, CLONE_NEWNET) < 0 ? -errno : 0;
}

struct kid *netns_kid_spawn(const struct netns_net *net, unsigned i, const char *name,
			    const char *const *argv, const char *out_path)
{
	struct kid *k;
	int r = netns_enter(net, i);

	if (r < 0) {
		fprintf(stderr, "netns: into %s: %s\n", i < net->n ? net->name[i] : "?",
			strerror(-r));
		return NULL;
	}
	/* The child is forked from this thread: it is born in host i's namespace. */
	k = kid_spawn(name, argv, out_path, 0);
	netns_leave();
	return k;
}

int netns_loss(const struct netns_net *net, unsigned i, unsigned pct)
{
	char match[48] = "";

	if (i >= net->n || pct > 100)
		return -1;
	if (cmd("ip netns exec %s nft 'add table inet rmdt; flush table inet rmdt'", net->name[i]) <
	    0)
		return -1;
	if (pct == 0)
		return 0;
	/* numgen's range is 0..99 ("mod 100 < 100" is refused): 100 % is a rule without it */
	if (pct < 100)
		snprintf(match, sizeof(match), "numgen random mod 100 < %u ", pct);
	return cmd("ip netns exec %s nft 'add chain inet rmdt in "
		   "{ type filter hook input priority 0; policy accept; }; "
		   "add rule inet rmdt in iifname \"eth0\" %sdrop'",
		   net->name[i], match);
}

unsigned netns_listed(const char *prefix, char *out, size_t size)
{
	FILE *p = popen("ip netns list", "r");
	char line[256];
	size_t len = 0;
	unsigned n = 0;

	if (size)
		out[0] = '\0';
	if (!p)
		return 0;
	while (fgets(line, sizeof(line), p)) {
		if (strncmp(line, prefix, strlen(prefix)) != 0)
			continue;
		n++;
		if (len < size) {
			snprintf(out + len, size - len, "%s", line);
			len += strlen(out + len);
		}
	}
	pclose(p);
	return n;
}
