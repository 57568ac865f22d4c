// SPDX-License-Identifier: MIT
/*
 * The LCM link: see rmd/lcm_link.h.
 *
 * Why the link sends on udpm:// itself rather than through lcm_publish():
 * the filter that keeps the link from reading back its own datagrams must
 * name the socket they leave from.  LCM does not tell which one that is;
 * finding it by looking through the process's descriptors for the one
 * UDP socket lcm_create() opened depends on how LCM opens its sockets, and
 * an LCM that opens two, or one later, leaves the filter off without a
 * word.  A socket of the link's own has a known address and port, and the
 * sending half of the wire format is a header and a loop (docs/design.md,
 * "The LCM link").
 */
#define _GNU_SOURCE

#include <ctype.h>
#include <dirent.h>
#include <errno.h>
#include <sched.h>
#include <stdatomic.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <time.h>
#include <unistd.h>

#include <arpa/inet.h>
#include <linux/filter.h>
#include <netinet/in.h>
#include <sys/socket.h>
#include <sys/uio.h>

#include <lcm/lcm.h>

#include "rmd/lcm_link.h"
#include "rmd/time.h"

_Static_assert(RMD_UDPM_CHANNEL_MAX == LCM_MAX_CHANNEL_NAME_LENGTH, "LCM's channel names");
_Static_assert(RMD_LCM_LINK_SHORT_MAX - RMD_LCM_LINK_FRAGMENT_MAX ==
		       RMD_UDPM_LONG_HDR - RMD_UDPM_SHORT_HDR,
	       "a fragment and a short message fill the same datagram");

/* LCM's udpm defaults (lcm/lcm_udpm.c: parse_mc_addr_and_port). */
#define UDPM_DEFAULT_GROUP "239.255.76.67"
#define UDPM_DEFAULT_PORT 7667
#define URL_MAX 512
#define TASKS_MAX 256

struct rmd_lcm_link {
	bool udpm;
	char prefix[RMD_UDPM_CHANNEL_MAX + 1];
	size_t prefix_len;
	char prefix2[RMD_UDPM_CHANNEL_MAX + 1]; /* "": none */
	size_t prefix2_len;

	/* udpm */
	int rx_fd, tx_fd;
	struct sockaddr_in own; /* tx_fd's address and port: its datagrams' source */
	uint32_t seqno;		/* the next message's (lcm_udpm_publish() counts alike) */
	bool filter, stamps;
	int filter_error, stamps_error, rcvbuf;
	struct rmd_udpm_rx rx;
	unsigned char pkt[RMD_UDPM_PKT_MAX];

	/* other providers */
	lcm_t *lcm;
	lcm_subscription_t *sub, *sub2;
	pid_t tid[RMD_LCM_LINK_THREADS];
	unsigned n_tid, n_tid_rt;
	/* the message lcm_handle() handed over (on_lcm), copied: LCM's is gone after it */
	bool got, got_long;
	struct rmd_lcm_msg got_msg;
	char channel[RMD_UDPM_CHANNEL_MAX + 1];
	unsigned char data[RMD_UDPM_MSG_MAX];

	/* written by the link's thread, read by rmd_lcm_link_info() from any */
	atomic_uint_fast64_t n_datagrams, n_own, n_published;
};

static void count(atomic_uint_fast64_t *c)
{
	atomic_fetch_add_explicit(c, 1, memory_order_relaxed);
}

/* ---- udpm: the URL ---------------------------------------------------------- */

struct udpm_url {
	struct sockaddr_in group;
	int ttl;
	int recv_buf_size; /* 0: not named */
};

/* A decimal option value in [lo, hi]; false when it is not one. */
static bool option_int(const char *v, size_t n, long lo, long hi, int *out)
{
	char buf[16], *end;
	long x;

	if (n == 0 || n >= sizeof(buf))
		return false;
	memcpy(buf, v, n);
	buf[n] = '\0';
	errno = 0;
	x = strtol(buf, &end, 10);
	if (errno || *end || x < lo || x > hi)
		return false;
	*out = (int)x;
	return true;
}

/*
 * "udpm://[group][:port][?ttl=N&recv_buf_size=N]", as LCM reads it: group
 * and port default to LCM's, ttl to 0.  An option LCM would not know is
 * refused rather than ignored.  0 or -EINVAL with the reason in err.
 */
static int parse_udpm(const char *url, struct udpm_url *u, char *err, size_t errlen)
{
	const char *net = url + strlen("udpm://"), *q = strchr(net, '?');
	size_t n = q ? (size_t)(q - net) : strlen(net), hn = strcspn(net, ":");
	char host[64];
	int port = UDPM_DEFAULT_PORT;

	memset(u, 0, sizeof(*u));
	if (hn > n)
		hn = n;
	if (hn >= sizeof(host))
		goto bad_group;
	memcpy(host, net, hn);
	host[hn] = '\0';
	if (hn < n && !option_int(net + hn + 1, n - hn - 1, 1, 65535, &port))
		goto bad_group;
	u->group.sin_family = AF_INET;
	u->group.sin_port = htons((uint16_t)port);
	if (!inet_aton(hn ? host : UDPM_DEFAULT_GROUP, &u->group.sin_addr) ||
	    !IN_MULTICAST(ntohl(u->group.sin_addr.s_addr)))
		goto bad_group;
	for (const char *o = q; o && *o;) {
		const char *k = o + 1, *eq = strchr(k, '='), *end = k + strcspn(k, "&");
		size_t kn = eq && eq < end ? (size_t)(eq - k) : 0;
		const char *v = k + kn + 1;
		bool ok;

		if (!kn)
			ok = false;
		else if (kn == 3 && !strncmp(k, "ttl", 3))
			ok = option_int(v, (size_t)(end - v), 0, 255, &u->ttl);
		else if (kn == 13 && !strncmp(k, "recv_buf_size", 13))
			ok = option_int(v, (size_t)(end - v), 1, INT32_MAX, &u->recv_buf_size);
		else
			ok = false;
		if (!ok) {
			snprintf(err, errlen,
				 "cannot create \"%s\": option \"%.*s\" (udpm knows ttl=0..255 "
				 "and recv_buf_size=bytes)",
				 url, (int)(end - k), k);
			return -EINVAL;
		}
		o = *end ? end : NULL;
	}
	return 0;

bad_group:
	snprintf(err, errlen,
		 "cannot create \"%s\": a bad URL, or multicast has no route (a multicast "
		 "group 224.0.0.0-239.255.255.255 and a port 1-65535)",
		 url);
	return -EINVAL;
}

/* ---- udpm: the sockets ------------------------------------------------------ */

/*
 * The receive socket, as LCM's provider opens its own: bound to the
 * group's port (shared, SO_REUSEADDR), in the group, with the receive
 * buffer asked, and the kernel's receive stamps.  The descriptor or -errno.
 */
static int open_rx(struct rmd_lcm_link *l, const struct udpm_url *u)
{
	struct ip_mreq mreq = { .imr_multiaddr = u->group.sin_addr,
				.imr_interface.s_addr = htonl(INADDR_ANY) };
	socklen_t len = sizeof(l->rcvbuf);
	int one = 1, fd = socket(AF_INET, SOCK_DGRAM | SOCK_CLOEXEC | SOCK_NONBLOCK, 0);

	if (fd < 0)
		return -errno;
	/* without stamps a message's arrival is when it is read: said, not fatal */
	l->stamps = setsockopt(fd, SOL_SOCKET, SO_TIMESTAMPNS, &one, sizeof(one)) == 0;
	l->stamps_error = l->stamps ? 0 : -errno;
	if (setsockopt(fd, SOL_SOCKET, SO_REUSEADDR, &one, sizeof(one)) < 0 ||
	    (u->recv_buf_size > 0 && setsockopt(fd, SOL_SOCKET, SO_RCVBUF, &u->recv_buf_size,
						sizeof(u->recv_buf_size)) < 0) ||
	    bind(fd, (const struct sockaddr *)&u->group, sizeof(u->group)) < 0 ||
	    setsockopt(fd, IPPROTO_IP, IP_ADD_MEMBERSHIP, &mreq, sizeof(mreq)) < 0) {
		int r = -errno;

		close(fd);
		return r;
	}
	if (getsockopt(fd, SOL_SOCKET, SO_RCVBUF, &l->rcvbuf, &len) < 0)
		l->rcvbuf = 0;
	return fd;
}

/*
 * The send socket, as LCM's (IP_MULTICAST_TTL from the URL, looped back to
 * the host so that its other processes hear it), but bound and connected
 * to the group: connect() is LCM's own test that the group has a route,
 * and fixes the source address and port every datagram will carry, which
 * the receive socket's filter then names.  The descriptor or -errno.
 */
static int open_tx(struct rmd_lcm_link *l, const struct udpm_url *u)
{
	struct sockaddr_in any = { .sin_family = AF_INET };
	socklen_t len = sizeof(l->own);
	unsigned char ttl = (unsigned char)u->ttl, loop = 1;
	int fd = socket(AF_INET, SOCK_DGRAM | SOCK_CLOEXEC, 0);

	if (fd < 0)
		return -errno;
	if (setsockopt(fd, IPPROTO_IP, IP_MULTICAST_TTL, &ttl, sizeof(ttl)) < 0 ||
	    setsockopt(fd, IPPROTO_IP, IP_MULTICAST_LOOP, &loop, sizeof(loop)) < 0 ||
	    bind(fd, (const struct sockaddr *)&any, sizeof(any)) < 0 ||
	    connect(fd, (const struct sockaddr *)&u->group, sizeof(u->group)) < 0 ||
	    getsockname(fd, (struct sockaddr *)&l->own, &len) < 0) {
		int r = -errno;

		close(fd);
		return r;
	}
	return fd;
}

/*
 * Drop, in the kernel, the datagrams that come from the send socket: the
 * link's own messages, which the kernel loops back to every member of the
 * group on this host.  Everything else passes.  0 or -errno (the filter
 * is then off: each own datagram is read and dropped by
 * rmd_lcm_link_receive(), which costs a read, nothing else).
 */
static int drop_own(int rx_fd, const struct sockaddr_in *own)
{
	/* a UDP socket's filter sees the UDP header at 0 (SKF_NET_OFF: the IP header) */
	struct sock_filter code[] = {
		BPF_STMT(BPF_LD | BPF_W | BPF_ABS, (uint32_t)SKF_NET_OFF + 12),
		BPF_JUMP(BPF_JMP | BPF_JEQ | BPF_K, ntohl(own->sin_addr.s_addr), 0, 3),
		BPF_STMT(BPF_LD | BPF_H | BPF_ABS, 0),
		BPF_JUMP(BPF_JMP | BPF_JEQ | BPF_K, ntohs(own->sin_port), 0, 1),
		BPF_STMT(BPF_RET | BPF_K, 0),
		BPF_STMT(BPF_RET | BPF_K, 0xFFFFFFFF),
	};
	struct sock_fprog prog = { .len = sizeof(code) / sizeof(code[0]), .filter = code };

	return setsockopt(rx_fd, SOL_SOCKET, SO_ATTACH_FILTER, &prog, sizeof(prog)) == 0 ? 0 :
											   -errno;
}

static int open_udpm(struct rmd_lcm_link *l, const struct rmd_lcm_link_opts *o, char *err,
		     size_t errlen)
{
	struct udpm_url u;
	int r = parse_udpm(o->url, &u, err, errlen);

	if (r < 0)
		return r;
	if (!u.recv_buf_size)
		u.recv_buf_size = o->recv_buf_size;
	l->tx_fd = open_tx(l, &u);
	if (l->tx_fd < 0) {
		snprintf(err, errlen,
			 "cannot create \"%s\": a bad URL, or multicast has no route (for "
			 "loopback: ip route add 224.0.0.0/4 dev lo src 127.0.0.1; "
			 "docs/lcm.md): %s",
			 o->url, strerror(-l->tx_fd));
		return -EIO;
	}
	l->rx_fd = open_rx(l, &u);
	if (l->rx_fd < 0) {
		snprintf(err, errlen,
			 "LCM \"%s\": cannot subscribe: %s (multicast not routable? see "
			 "docs/lcm.md)",
			 o->url, strerror(-l->rx_fd));
		return -EIO;
	}
	l->filter_error = drop_own(l->rx_fd, &l->own);
	l->filter = l->filter_error == 0;
	rmd_udpm_rx_init(&l->rx);
	l->udpm = true;
	return 0;
}

/* ---- other providers: LCM's own path ----------------------------------------- */

/*
 * The thread ids in /proc/self/task, at most max; how many.  The threads
 * that appear while LCM is created and subscribed are LCM's.
 */
static unsigned list_tasks(pid_t *id, unsigned max)
{
	DIR *d = opendir("/proc/self/task");
	struct dirent *e;
	unsigned n = 0;

	if (!d)
		return 0;
	while ((e = readdir(d)) && n < max)
		if (e->d_name[0] != '.')
			id[n++] = (pid_t)atoi(e->d_name);
	closedir(d);
	return n;
}

static void find_lcm_threads(struct rmd_lcm_link *l, const pid_t *before, unsigned n_before)
{
	pid_t now[TASKS_MAX];
	unsigned n = list_tasks(now, TASKS_MAX);

	for (unsigned i = 0; i < n && l->n_tid < RMD_LCM_LINK_THREADS; i++) {
		bool old = false;

		for (unsigned j = 0; j < n_before && !old; j++)
			old = now[i] == before[j];
		if (!old)
			l->tid[l->n_tid++] = now[i];
	}
}

/* LCM subscribes by regular expression: the prefix (escaped but for letters, digits, _) and ".*". */
static void prefix_regex(char *out, size_t len, const char *prefix)
{
	size_t k = 0;

	for (; *prefix && k + 3 < len; prefix++) {
		if (!isalnum((unsigned char)*prefix) && *prefix != '_')
			out[k++] = '\\';
		out[k++] = *prefix;
	}
	snprintf(out + k, len - k, ".*");
}

/* LCM's recv_utime (CLOCK_REALTIME, us) in ns; 0 (none) when out of range. */
static int64_t utime_ns(int64_t us)
{
	int64_t ns;

	return us > 0 && !__builtin_mul_overflow(us, RMD_NS_PER_US, &ns) ? ns : 0;
}

/* lcm_handle()'s call: the message copied, for rmd_lcm_link_receive() to hand over. */
static void on_lcm(const lcm_recv_buf_t *rbuf, const char *channel, void *user)
{
	struct rmd_lcm_link *l = user;

	snprintf(l->channel, sizeof(l->channel), "%s", channel);
	l->got = true;
	l->got_long = rbuf->data_size > RMD_UDPM_MSG_MAX;
	if (!l->got_long)
		memcpy(l->data, rbuf->data, rbuf->data_size);
	l->got_msg = (struct rmd_lcm_msg){
		.channel = l->channel,
		.data = l->got_long ? NULL : l->data,
		.size = rbuf->data_size,
		.rx_real_ns = utime_ns(rbuf->recv_utime),
	};
}

static int open_lcm(struct rmd_lcm_link *l, const struct rmd_lcm_link_opts *o, char *err,
		    size_t errlen)
{
	char re[2 * RMD_UDPM_CHANNEL_MAX + 8];
	pid_t before[TASKS_MAX];
	unsigned n_before = list_tasks(before, TASKS_MAX);

	l->lcm = lcm_create(o->url);
	if (!l->lcm) {
		snprintf(err, errlen,
			 "cannot create \"%s\": a bad URL, or multicast has no route (for "
			 "loopback: ip route add 224.0.0.0/4 dev lo src 127.0.0.1; docs/lcm.md)",
			 o->url);
		return -EIO;
	}
	prefix_regex(re, sizeof(re), l->prefix);
	l->sub = lcm_subscribe(l->lcm, re, on_lcm, l);
	if (!l->sub) {
		snprintf(err, errlen, "LCM \"%s\": cannot subscribe", o->url);
		return -EIO;
	}
	if (o->queue)
		lcm_subscription_set_queue_capacity(l->sub, (int)o->queue);
	/* a second prefix inside the first is received already: subscribed twice, twice over */
	if (l->prefix2[0] && strncmp(l->prefix2, l->prefix, l->prefix_len) != 0) {
		prefix_regex(re, sizeof(re), l->prefix2);
		l->sub2 = lcm_subscribe(l->lcm, re, on_lcm, l);
		if (!l->sub2) {
			snprintf(err, errlen, "LCM \"%s\": cannot subscribe", o->url);
			return -EIO;
		}
	}
	find_lcm_threads(l, before, n_before);
	return 0;
}

/* ---- the interface ------------------------------------------------------------ */

int rmd_lcm_link_new(struct rmd_lcm_link **out, const struct rmd_lcm_link_opts *o, char *err,
		     size_t errlen)
{
	struct rmd_lcm_link *l;
	int r;

	*out = NULL;
	if (!o->url || strlen(o->url) >= URL_MAX) {
		snprintf(err, errlen, "no LCM URL, or one longer than %d characters", URL_MAX - 1);
		return -EINVAL;
	}
	if ((o->prefix && strlen(o->prefix) > RMD_UDPM_CHANNEL_MAX) ||
	    (o->prefix2 && strlen(o->prefix2) > RMD_UDPM_CHANNEL_MAX)) {
		snprintf(err, errlen, "channel prefix longer than %d characters",
			 RMD_UDPM_CHANNEL_MAX);
		return -EINVAL;
	}
	l = calloc(1, sizeof(*l));
	if (!l) {
		snprintf(err, errlen, "out of memory");
		return -ENOMEM;
	}
	l->rx_fd = l->tx_fd = -1;
	snprintf(l->prefix, sizeof(l->prefix), "%s", o->prefix ? o->prefix : "");
	l->prefix_len = strlen(l->prefix);
	snprintf(l->prefix2, sizeof(l->prefix2), "%s", o->prefix2 ? o->prefix2 : "");
	l->prefix2_len = strlen(l->prefix2);
	r = strncmp(o->url, "udpm://", 7) == 0 ? open_udpm(l, o, err, errlen) :
						 open_lcm(l, o, err, errlen);
	if (r < 0) {
		rmd_lcm_link_free(l);
		return r;
	}
	*out = l;
	return 0;
}

void rmd_lcm_link_free(struct rmd_lcm_link *l)
{
	if (!l)
		return;
	if (l->lcm) {
		if (l->sub)
			lcm_unsubscribe(l->lcm, l->sub);
		if (l->sub2)
			lcm_unsubscribe(l->lcm, l->sub2);
		lcm_destroy(l->lcm);
	}
	if (l->rx_fd >= 0)
		close(l->rx_fd);
	if (l->tx_fd >= 0)
		close(l->tx_fd);
	free(l);
}

int rmd_lcm_link_fd(const struct rmd_lcm_link *l)
{
	return l->udpm ? l->rx_fd : lcm_get_fileno(l->lcm);
}

/* The kernel's receive stamp of a datagram (SO_TIMESTAMPNS), CLOCK_REALTIME ns; 0: none. */
static int64_t rx_stamp_ns(struct msghdr *mh)
{
	for (struct cmsghdr *c = CMSG_FIRSTHDR(mh); c; c = CMSG_NXTHDR(mh, c))
		if (c->cmsg_level == SOL_SOCKET && c->cmsg_type == SCM_TIMESTAMPNS &&
		    c->cmsg_len >= CMSG_LEN(sizeof(struct timespec))) {
			struct timespec ts;

			memcpy(&ts, CMSG_DATA(c), sizeof(ts));
			return rmd_timespec_ns(&ts);
		}
	return 0;
}

static bool in_prefix(const struct rmd_lcm_link *l, const char *channel)
{
	return strncmp(channel, l->prefix, l->prefix_len) == 0 ||
	       (l->prefix2_len && strncmp(channel, l->prefix2, l->prefix2_len) == 0);
}

static int receive_udpm(struct rmd_lcm_link *l, struct rmd_lcm_msg *m)
{
	struct sockaddr_in from;
	union {
		char buf[CMSG_SPACE(sizeof(struct timespec))];
		struct cmsghdr align;
	} ctl;
	struct iovec iov = { .iov_base = l->pkt, .iov_len = sizeof(l->pkt) };
	struct msghdr mh = { .msg_name = &from,
			     .msg_namelen = sizeof(from),
			     .msg_iov = &iov,
			     .msg_iovlen = 1,
			     .msg_control = ctl.buf,
			     .msg_controllen = sizeof(ctl.buf) };
	struct rmd_udpm_msg um;
	enum rmd_udpm_verdict v;
	ssize_t r = recvmsg(l->rx_fd, &mh, MSG_DONTWAIT);

	if (r < 0)
		return errno == EWOULDBLOCK ? -EAGAIN : -errno;
	count(&l->n_datagrams);
	if (from.sin_addr.s_addr == l->own.sin_addr.s_addr && from.sin_port == l->own.sin_port) {
		count(&l->n_own); /* the filter is off */
		return 0;
	}
	v = rmd_udpm_rx_packet(&l->rx, from.sin_addr.s_addr, from.sin_port, l->pkt, (size_t)r, &um);
	if (v != RMD_UDPM_MESSAGE && v != RMD_UDPM_TOO_LONG)
		return 0;
	/* too long: known only when this datagram named its channel */
	if (!um.channel[0] || !in_prefix(l, um.channel))
		return 0;
	*m = (struct rmd_lcm_msg){ .channel = um.channel,
				   .data = v == RMD_UDPM_MESSAGE ? um.data : NULL,
				   .size = um.size,
				   .rx_real_ns = rx_stamp_ns(&mh) };
	return v == RMD_UDPM_MESSAGE ? 1 : -EMSGSIZE;
}

static int receive_lcm(struct rmd_lcm_link *l, struct rmd_lcm_msg *m)
{
	int r;

	l->got = false;
	r = lcm_handle_timeout(l->lcm, 0);
	if (r < 0)
		return -EIO;
	if (r == 0)
		return -EAGAIN;
	if (!l->got)
		return 0;
	*m = l->got_msg;
	return l->got_long ? -EMSGSIZE : 1;
}

int rmd_lcm_link_receive(struct rmd_lcm_link *l, struct rmd_lcm_msg *m)
{
	*m = (struct rmd_lcm_msg){ .channel = "" };
	return l->udpm ? receive_udpm(l, m) : receive_lcm(l, m);
}

/* One datagram: the header, the channel and its NUL (or nothing), and len bytes of data. */
static int send_datagram(struct rmd_lcm_link *l, const unsigned char *hdr, size_t hdr_len,
			 const char *channel, size_t channel_len, const void *data, size_t len)
{
	struct iovec iov[3] = {
		{ .iov_base = (void *)hdr, .iov_len = hdr_len },
		{ .iov_base = (void *)channel, .iov_len = channel_len },
		{ .iov_base = (void *)data, .iov_len = len },
	};
	struct msghdr mh = { .msg_iov = iov, .msg_iovlen = 3 };
	ssize_t r;

	do
		r = sendmsg(l->tx_fd, &mh, 0);
	while (r < 0 && errno == EINTR);
	return r < 0 ? -errno : 0;
}

/*
 * lcm_udpm_publish()'s cut (LCM 1.3.1 and 1.5): channel, NUL and data in
 * one "LC02" datagram when they fit RMD_LCM_LINK_SHORT_MAX; else "LC03"
 * fragments of RMD_LCM_LINK_FRAGMENT_MAX bytes, the first holding the
 * channel and its NUL and the rest of its room in data, fragment_offset
 * counting data bytes only.
 */
static int publish_udpm(struct rmd_lcm_link *l, const char *channel, size_t cl,
			const unsigned char *data, size_t size)
{
	unsigned char hdr[RMD_UDPM_LONG_HDR];
	size_t total = cl + 1 + size, count, off;
	uint32_t seqno = l->seqno++;
	int r;

	if (total <= RMD_LCM_LINK_SHORT_MAX) {
		rmd_udpm_put_short_header(hdr, seqno);
		return send_datagram(l, hdr, RMD_UDPM_SHORT_HDR, channel, cl + 1, data, size);
	}
	count = total / RMD_LCM_LINK_FRAGMENT_MAX + !!(total % RMD_LCM_LINK_FRAGMENT_MAX);
	if (count > UINT16_MAX || size > UINT32_MAX)
		return -EINVAL;
	off = RMD_LCM_LINK_FRAGMENT_MAX - (cl + 1);
	rmd_udpm_put_fragment_header(hdr, seqno, (uint32_t)size, 0, 0, (uint16_t)count);
	r = send_datagram(l, hdr, RMD_UDPM_LONG_HDR, channel, cl + 1, data, off);
	for (size_t no = 1; r == 0 && no < count; no++) {
		size_t len = size - off < RMD_LCM_LINK_FRAGMENT_MAX ? size - off :
								      RMD_LCM_LINK_FRAGMENT_MAX;

		rmd_udpm_put_fragment_header(hdr, seqno, (uint32_t)size, (uint32_t)off,
					     (uint16_t)no, (uint16_t)count);
		r = send_datagram(l, hdr, RMD_UDPM_LONG_HDR, NULL, 0, data + off, len);
		off += len;
	}
	return r;
}

int rmd_lcm_link_publish(struct rmd_lcm_link *l, const char *channel, const void *data, size_t size)
{
	size_t cl = strnlen(channel, RMD_UDPM_CHANNEL_MAX + 1);
	int r;

	if (cl > RMD_UDPM_CHANNEL_MAX)
		return -EINVAL;
	if (l->udpm)
		r = publish_udpm(l, channel, cl, data, size);
	else
		r = size > UINT32_MAX || lcm_publish(l->lcm, channel, data, (unsigned)size) < 0 ?
			    -EIO :
			    0;
	if (r == 0)
		count(&l->n_published);
	return r;
}

int rmd_lcm_link_raise(struct rmd_lcm_link *l, unsigned rt_priority)
{
	struct sched_param sp = { .sched_priority = (int)rt_priority };
	int r = 0;

	l->n_tid_rt = 0;
	if (!rt_priority)
		return 0;
	for (unsigned i = 0; i < l->n_tid; i++) {
		if (sched_setscheduler(l->tid[i], SCHED_FIFO, &sp) == 0)
			l->n_tid_rt++;
		else if (errno != ESRCH && !r) /* gone: nothing to raise */
			r = -errno;
	}
	return r ? r : (int)l->n_tid_rt;
}

void rmd_lcm_link_info(const struct rmd_lcm_link *l, struct rmd_lcm_link_info *info)
{
	*info = (struct rmd_lcm_link_info){
		.udpm = l->udpm,
		.filter = l->filter,
		.filter_error = l->filter_error,
		.stamps = l->stamps,
		.stamps_error = l->stamps_error,
		.rcvbuf = l->rcvbuf,
		.lcm_threads = l->n_tid,
		.lcm_threads_rt = l->n_tid_rt,
		.datagrams = atomic_load_explicit(&l->n_datagrams, memory_order_relaxed),
		.own_read = atomic_load_explicit(&l->n_own, memory_order_relaxed),
		.published = atomic_load_explicit(&l->n_published, memory_order_relaxed),
	};
}
