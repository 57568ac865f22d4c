// SPDX-License-Identifier: MIT
/*
 * SocketCAN transport: one non-blocking raw CAN socket per interface,
 * batched with sendmmsg(2)/recvmmsg(2), kernel receive timestamps, error
 * frames folded into the bus state.  See rmd/bus_socketcan.h.
 */
#define _GNU_SOURCE /* sendmmsg, recvmmsg */

#include <errno.h>
#include <stdarg.h>
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <time.h>
#include <unistd.h>

#include <net/if.h>
#include <net/if_arp.h>
#include <sys/ioctl.h>
#include <sys/socket.h>
#include <sys/uio.h>

#include <linux/can.h>
#include <linux/can/error.h>
#include <linux/can/netlink.h>
#include <linux/can/raw.h>
#include <linux/netlink.h>
#include <linux/rtnetlink.h>

#include "rmd/dialect.h"
#include "rmd/err.h"
#include "rmd/time.h"
#include "rmd/bus_socketcan.h"

#define BATCH RMD_SOCKETCAN_BATCH

/* recvmmsg(2) calls one recv() makes at most, so an error-frame flood cannot hold the rt loop. */
#define RX_MAX_CALLS 8

/*
 * Exact match on one 11-bit identifier, data frames only: with
 * CAN_EFF_FLAG and CAN_RTR_FLAG in the mask the kernel drops extended and
 * remote frames itself, and files the filter in its per-identifier table
 * (O(1) per received frame, however many motors there are).
 */
#define SFF_EXACT_MASK (CAN_SFF_MASK | CAN_EFF_FLAG | CAN_RTR_FLAG)

/*
 * Error classes that tell us about the bus.  CAN_ERR_LOSTARB is left out:
 * the motors' replies win arbitration over our requests all the time, that
 * is normal traffic.  PROT/ACK/BUSERROR only arrive when the interface has
 * `berr-reporting on`; an ACK error then means no motor acknowledged.
 */
#define ERR_CLASSES                                                                     \
	(CAN_ERR_TX_TIMEOUT | CAN_ERR_CRTL | CAN_ERR_PROT | CAN_ERR_TRX | CAN_ERR_ACK | \
	 CAN_ERR_BUSOFF | CAN_ERR_BUSERROR | CAN_ERR_RESTARTED)

/* Ancillary data of one received frame: receive time and the socket's drop counter. */
#define CTRL_LEN (CMSG_SPACE(sizeof(struct timespec)) + CMSG_SPACE(sizeof(uint32_t)))

union ctrl_buf {
	char buf[CTRL_LEN];
	struct cmsghdr align;
};

struct socketcan {
	int fd;
	char ifname[IFNAMSIZ];
	struct rmd_socketcan_errs errs;
	int rcvbuf;			  /* bytes the kernel granted */
	uint32_t drops_seen;		  /* last SO_RXQ_OVFL value: frames the kernel dropped */
	int64_t last_rx_ns, stamp_gap_ns; /* rmd_bus_stamp_seen() */
	struct mmsghdr tx_msg[BATCH];
	struct iovec tx_iov[BATCH];
	struct can_frame tx_cf[BATCH];
	struct mmsghdr rx_msg[BATCH];
	struct iovec rx_iov[BATCH];
	struct can_frame rx_cf[BATCH];
	union ctrl_buf rx_ctrl[BATCH];
};

static int add_filter(struct can_filter *f, int n, canid_t id)
{
	for (int i = 0; i < n; i++)
		if (f[i].can_id == id)
			return n;
	f[n].can_id = id;
	f[n].can_mask = SFF_EXACT_MASK;
	return n + 1;
}

/* Filters a stray watch adds at most: two ranges of 32 ids per identifier base. */
#define STRAY_FILTERS (4 * RMD_PROTO_COUNT)

/* The identifiers base + 1 .. base + 32 (ID 1..32): base .. base + 31, and base + 32.  Non-rt. */
static int add_ids(struct can_filter *f, int n, canid_t base)
{
	const canid_t mask = SFF_EXACT_MASK & ~0x1Fu;
	bool have = false;

	for (int i = 0; i < n; i++)
		have |= f[i].can_id == base && f[i].can_mask == mask;
	if (!have) {
		f[n].can_id = base;
		f[n].can_mask = mask;
		n++;
	}
	return add_filter(f, n, base + RMD_MAX_MOTORS);
}

/*
 * struct rmd_socketcan_opts.watch_strays: the reply identifiers of every ID
 * a V2 0x280 frame would command (rmd_dialect_takes_280()): V2 motors 1..4
 * (V2 §4.1), any ID of the other dialects, on their replies and control
 * replies (V3 §3).  Non-rt.
 */
static int add_stray_filters(struct can_filter *f, int n)
{
	size_t nd;
	const struct rmd_dialect *all = rmd_dialect_list(&nd);

	for (size_t k = 0; k < nd; k++) {
		const struct rmd_dialect *d = &all[k];

		if (rmd_dialect_has(d, RMD_DIALECT_BATCH_280)) {
			for (canid_t id = 1; id <= 4; id++)
				n = add_filter(f, n, d->reply_base + id);
			continue;
		}
		n = add_ids(f, n, d->reply_base);
		if (d->ctl_reply_base != d->reply_base)
			n = add_ids(f, n, d->ctl_reply_base);
	}
	return n;
}

/* Reply identifiers of the configured motors -> kernel filters.  Non-rt. */
static int build_filters(const char *ifname, const struct rmd_socketcan_opts *opts,
			 struct can_filter *f, char *err, size_t errlen)
{
	int n = 0;

	if (!opts) {
		/* Sniffer: every standard data frame. */
		f[0].can_id = 0;
		f[0].can_mask = CAN_EFF_FLAG | CAN_RTR_FLAG;
		return 1;
	}
	if (opts->device) {
		/* V2 §1, V3 §1.1.2: requests 0x140 + ID, 0x280, 0x300, MIT 0x400 + ID (ID 1..32). */
		static const struct can_filter requests[] = {
			{ RMD_CAN_REQ_BASE, SFF_EXACT_MASK & ~0x1Fu }, /* 0x140..0x15F */
			{ RMD_CAN_REQ_BASE + 32, SFF_EXACT_MASK },
			{ RMD_CAN_MULTI, SFF_EXACT_MASK },
			{ RMD_CAN_SET_ID, SFF_EXACT_MASK },
			{ RMD_CAN_MIT_REQ_BASE, SFF_EXACT_MASK & ~0x1Fu }, /* 0x400..0x41F */
			{ RMD_CAN_MIT_REQ_BASE + 32, SFF_EXACT_MASK },
		};

		memcpy(f, requests, sizeof(requests));
		return (int)(sizeof(requests) / sizeof(requests[0]));
	}
	if (opts->n_motors && !opts->motors)
		return rmd_errf(err, errlen, -EINVAL, "%s: %u motors but no motor list", ifname,
				opts->n_motors);
	for (unsigned i = 0; i < opts->n_motors; i++) {
		const struct rmd_socketcan_motor *m = &opts->motors[i];
		const struct rmd_dialect *d;

		if (m->id < 1 || m->id > RMD_MAX_MOTORS)
			return rmd_errf(err, errlen, -EINVAL, "%s: motor id %u out of range 1..%d",
					ifname, m->id, RMD_MAX_MOTORS);
		d = rmd_dialect(m->proto);
		if (!d)
			return rmd_errf(err, errlen, -EINVAL, "%s: motor %u: unknown protocol %d",
					ifname, m->id, (int)m->proto);
		/* its replies (V2 §1: on 0x140 + ID, shared with requests) */
		n = add_filter(f, n, d->reply_base + m->id);
		/* `protocol: auto`: bring-up asks in every dialect (rmd/bringup.h) */
		if (m->any_dialect) {
			size_t nd;
			const struct rmd_dialect *all = rmd_dialect_list(&nd);

			for (size_t k = 0; k < nd; k++)
				if (rmd_dialect_is_firmware(&all[k]))
					n = add_filter(f, n, all[k].reply_base + m->id);
		}
		/*
		 * V3 §5, V4.2 §5: MIT replies on 0x500 + ID; the motor's
		 * firmware still answers probes (0xB5, 0x9A) on 0x240 + ID.
		 */
		if (((opts->mit_ids >> (m->id - 1)) & 1) || d->ctl_reply_base != d->reply_base)
			n = add_filter(f, n, RMD_CAN_MIT_REPLY_BASE + m->id);
	}
	if (opts->set_id_replies)
		n = add_filter(f, n, RMD_CAN_SET_ID); /* V3 §4.4: 0x79 replies on 0x300 */
	if (opts->watch_strays)
		n = add_stray_filters(f, n);
	return n;
}

/*
 * vcan and vxcan have no bitrate to set.  Told apart by their conventional
 * names: the link kind is only available over rtnetlink.
 */
static bool is_virtual_can(const char *ifname)
{
	return !strncmp(ifname, "vcan", 4) || !strncmp(ifname, "vxcan", 5);
}

static unsigned suggested_txqueuelen(unsigned burst)
{
	unsigned q = 128;

	while (q < 2ull * burst && q < (1u << 20))
		q *= 2;
	return q;
}

/* Interface checks with messages that name the fix.  Non-rt. */
static int check_interface(int fd, const char *ifname, const struct rmd_socketcan_opts *opts,
			   bool *carrier, char *err, size_t errlen)
{
	struct ifreq ifr;

	memset(&ifr, 0, sizeof(ifr));
	memcpy(ifr.ifr_name, ifname, strlen(ifname) + 1);

	if (ioctl(fd, SIOCGIFHWADDR, &ifr) < 0)
		return rmd_errf(err, errlen, -errno, "%s: SIOCGIFHWADDR: %s", ifname,
				strerror(errno));
	if (ifr.ifr_hwaddr.sa_family != ARPHRD_CAN)
		return rmd_errf(
			err, errlen, -ENODEV,
			"%s: not a CAN interface (link type %u): list them with `ip -details link show`",
			ifname, ifr.ifr_hwaddr.sa_family);

	if (ioctl(fd, SIOCGIFFLAGS, &ifr) < 0)
		return rmd_errf(err, errlen, -errno, "%s: SIOCGIFFLAGS: %s", ifname,
				strerror(errno));
	if (!(ifr.ifr_flags & IFF_UP) && opts && opts->device) {
		*carrier = false; /* the simulator waits for it to come up */
		return 0;
	}
	if (!(ifr.ifr_flags & IFF_UP)) {
		if (is_virtual_can(ifname))
			return rmd_errf(err, errlen, -ENETDOWN,
					"%s: interface is down: run `ip link set %s up`", ifname,
					ifname);
		return rmd_errf(
			err, errlen, -ENETDOWN,
			"%s: interface is down: run `ip link set %s up type can bitrate 1000000 restart-ms 100`",
			ifname, ifname);
	}
	/* A CAN controller drops its carrier while bus-off. */
	*carrier = ifr.ifr_flags & IFF_RUNNING;

	if (ioctl(fd, SIOCGIFTXQLEN, &ifr) < 0)
		return rmd_errf(err, errlen, -errno, "%s: SIOCGIFTXQLEN: %s", ifname,
				strerror(errno));
	/*
	 * txqueuelen 0: the device has no transmit queue to overflow.  (vcan
	 * reports 1000 but runs the noqueue qdisc: it takes every frame inside
	 * sendmsg, and only a real controller's queue ever fills.)
	 */
	if (opts && opts->burst && ifr.ifr_qlen > 0 && (unsigned)ifr.ifr_qlen < opts->burst)
		return rmd_errf(
			err, errlen, -ENOBUFS,
			"%s: txqueuelen %d cannot hold a %u-frame cycle: run `ip link set %s txqueuelen %u`",
			ifname, ifr.ifr_qlen, opts->burst, ifname,
			suggested_txqueuelen(opts->burst));
	return 0;
}

static int set_int(int fd, int level, int name, int val)
{
	return setsockopt(fd, level, name, &val, sizeof(val)) < 0 ? -errno : 0;
}

/* Socket options and bind.  Non-rt. */
static int setup_socket(int fd, const char *ifname, unsigned ifindex,
			const struct rmd_socketcan_opts *opts, int *rcvbuf, char *err,
			size_t errlen)
{
	struct can_filter filters[3 * RMD_MAX_MOTORS + 1 + STRAY_FILTERS];
	struct sockaddr_can addr;
	can_err_mask_t err_mask = ERR_CLASSES;
	int want = opts && opts->rcvbuf_bytes > 0 ? opts->rcvbuf_bytes :
						    RMD_SOCKETCAN_RCVBUF_DEFAULT;
	socklen_t len;
	int n, r;

	/* Filters before bind: no foreign frame is ever queued. */
	n = build_filters(ifname, opts, filters, err, errlen);
	if (n < 0)
		return n;
	if (setsockopt(fd, SOL_CAN_RAW, CAN_RAW_FILTER, n ? filters : NULL,
		       (socklen_t)(n * sizeof(filters[0]))) < 0)
		return rmd_errf(err, errlen, -errno, "%s: CAN_RAW_FILTER: %s", ifname,
				strerror(errno));
	if (setsockopt(fd, SOL_CAN_RAW, CAN_RAW_ERR_FILTER, &err_mask, sizeof(err_mask)) < 0)
		return rmd_errf(err, errlen, -errno, "%s: CAN_RAW_ERR_FILTER: %s", ifname,
				strerror(errno));
	r = set_int(fd, SOL_CAN_RAW, CAN_RAW_RECV_OWN_MSGS, 0);
	if (r < 0)
		return rmd_errf(err, errlen, r, "%s: CAN_RAW_RECV_OWN_MSGS: %s", ifname,
				strerror(-r));

	/* SO_RCVBUFFORCE passes net.core.rmem_max with CAP_NET_ADMIN; else capped there. */
	if (set_int(fd, SOL_SOCKET, SO_RCVBUFFORCE, want) < 0) {
		r = set_int(fd, SOL_SOCKET, SO_RCVBUF, want);
		if (r < 0)
			return rmd_errf(err, errlen, r, "%s: SO_RCVBUF: %s", ifname, strerror(-r));
	}
	len = sizeof(*rcvbuf);
	if (getsockopt(fd, SOL_SOCKET, SO_RCVBUF, rcvbuf, &len) < 0)
		*rcvbuf = 0;

	r = set_int(fd, SOL_SOCKET, SO_TIMESTAMPNS, 1);
	if (r < 0)
		return rmd_errf(err, errlen, r, "%s: SO_TIMESTAMPNS: %s", ifname, strerror(-r));
	r = set_int(fd, SOL_SOCKET, SO_RXQ_OVFL, 1);
	if (r < 0)
		return rmd_errf(err, errlen, r, "%s: SO_RXQ_OVFL: %s", ifname, strerror(-r));

	memset(&addr, 0, sizeof(addr));
	addr.can_family = AF_CAN;
	addr.can_ifindex = (int)ifindex;
	if (bind(fd, (struct sockaddr *)&addr, sizeof(addr)) < 0)
		return rmd_errf(err, errlen, -errno, "%s: bind: %s", ifname, strerror(errno));
	return 0;
}

/* Point every message header at its own frame and control buffer.  Non-rt. */
static void init_batches(struct socketcan *p)
{
	for (int i = 0; i < BATCH; i++) {
		p->tx_iov[i].iov_base = &p->tx_cf[i];
		p->tx_iov[i].iov_len = sizeof(p->tx_cf[i]);
		p->tx_msg[i].msg_hdr.msg_iov = &p->tx_iov[i];
		p->tx_msg[i].msg_hdr.msg_iovlen = 1;

		p->rx_iov[i].iov_base = &p->rx_cf[i];
		p->rx_iov[i].iov_len = sizeof(p->rx_cf[i]);
		p->rx_msg[i].msg_hdr.msg_iov = &p->rx_iov[i];
		p->rx_msg[i].msg_hdr.msg_iovlen = 1;
		p->rx_msg[i].msg_hdr.msg_control = p->rx_ctrl[i].buf;
		p->rx_msg[i].msg_hdr.msg_controllen = sizeof(p->rx_ctrl[i].buf);
	}
}

/* bus->state from what e says: bus-off, else no-ack, else the controller's.  Rt-safe. */
static void fold_state(struct rmd_bus *bus, const struct rmd_socketcan_errs *e)
{
	enum rmd_bus_state st = e->ctrl == RMD_BUS_OFF ? RMD_BUS_OFF :
				e->no_ack	       ? RMD_BUS_NO_ACK :
							 e->ctrl;

	if (st != bus->state) {
		bus->state = st;
		bus->stats.state_changes++;
	}
}

/* The queue refused frames: while the transmitter is error-passive, nobody acknowledges.  Rt-safe. */
static void queue_full(struct rmd_bus *bus, struct socketcan *p)
{
	if (p->errs.tx_passive && !p->errs.no_ack) {
		p->errs.no_ack = true;
		fold_state(bus, &p->errs);
	}
}

/* A data frame arrived: a powered node talks, so it acknowledges.  Rt-safe. */
static void heard(struct rmd_bus *bus, struct socketcan *p)
{
	if (__builtin_expect(p->errs.no_ack | (p->errs.ack_errors != 0), 0)) {
		p->errs.no_ack = false;
		p->errs.ack_errors = 0;
		fold_state(bus, &p->errs);
	}
}

/* rt-safe */
static int socketcan_send(struct rmd_bus *bus, const struct rmd_frame *frames, unsigned n,
			  int64_t now_ns)
{
	struct socketcan *p = bus->priv;
	int r;

	(void)now_ns;
	if (n > BATCH)
		n = BATCH;
	if (n == 0)
		return 0;
	for (unsigned i = 0; i < n; i++) {
		struct can_frame *cf = &p->tx_cf[i];

		if (frames[i].can_id > CAN_SFF_MASK || frames[i].len > CAN_MAX_DLEN)
			return -EINVAL;
		memset(cf, 0, sizeof(*cf));
		cf->can_id = frames[i].can_id;
		cf->len = frames[i].len;
		memcpy(cf->data, frames[i].data, frames[i].len);
	}
	do {
		r = sendmmsg(p->fd, p->tx_msg, n, MSG_DONTWAIT);
	} while (r < 0 && errno == EINTR);
	if (r < 0) {
		if (errno == ENOBUFS || errno == EAGAIN) {
			bus->stats.tx_busy += n;
			queue_full(bus, p);
			return 0;
		}
		return -errno;
	}
	/* A short count means frame r was refused; the kernel does not say why. */
	bus->stats.tx_frames += (unsigned)r;
	bus->stats.tx_busy += n - (unsigned)r;
	if ((unsigned)r < n)
		queue_full(bus, p);
	return r;
}

/*
 * Fold the ancillary data of one frame in: its receive time and the drop
 * counter.  The kernel stamps a frame with CLOCK_REALTIME (skb->tstamp,
 * when the driver hands it to the stack): moved onto CLOCK_MONOTONIC by
 * offset_ns, rmd_realtime_offset_ns() read right after the frames were
 * dequeued (it drifts < 0.5 us over the ~1 ms a frame waits in the
 * socket), and clamped to the dequeue time (rmd/time.h).  Rt-safe.
 */
static int64_t rx_ancillary(struct rmd_bus *bus, struct socketcan *p, struct msghdr *mh,
			    int64_t offset_ns, int64_t mono_now_ns)
{
	int64_t t_ns = mono_now_ns;

	for (struct cmsghdr *c = CMSG_FIRSTHDR(mh); c; c = CMSG_NXTHDR(mh, c)) {
		if (c->cmsg_level != SOL_SOCKET)
			continue;
		if (c->cmsg_type == SO_TIMESTAMPNS &&
		    c->cmsg_len >= CMSG_LEN(sizeof(struct timespec))) {
			struct timespec ts;

			memcpy(&ts, CMSG_DATA(c), sizeof(ts));
			t_ns = rmd_timespec_ns(&ts) - offset_ns;
			if (t_ns > mono_now_ns)
				t_ns = mono_now_ns;
		} else if (c->cmsg_type == SO_RXQ_OVFL &&
			   c->cmsg_len >= CMSG_LEN(sizeof(uint32_t))) {
			uint32_t drops;

			memcpy(&drops, CMSG_DATA(c), sizeof(drops));
			/* Frames lost to a full receive buffer are receive errors. */
			bus->stats.rx_errors += (uint32_t)(drops - p->drops_seen);
			p->drops_seen = drops;
		}
	}
	return t_ns;
}

/* rt-safe */
static int socketcan_recv(struct rmd_bus *bus, struct rmd_bus_rx *out, unsigned max, int64_t now_ns)
{
	struct socketcan *p = bus->priv;
	unsigned count = 0;

	(void)now_ns;
	for (int call = 0; call < RX_MAX_CALLS && count < max; call++) {
		unsigned want = max - count < BATCH ? max - count : BATCH;
		int64_t offset_ns, mono_now_ns;
		int r;

		for (unsigned i = 0; i < want; i++)
			p->rx_msg[i].msg_hdr.msg_controllen = sizeof(p->rx_ctrl[i].buf);
		do {
			r = recvmmsg(p->fd, p->rx_msg, want, MSG_DONTWAIT, NULL);
		} while (r < 0 && errno == EINTR);
		if (r < 0) {
			if (errno == EAGAIN)
				break;
			/* Keep what we have; the error is reported on the next call. */
			return count ? (int)count : -errno;
		}
		offset_ns = rmd_realtime_offset_ns(&mono_now_ns);
		for (int i = 0; i < r; i++) {
			struct msghdr *mh = &p->rx_msg[i].msg_hdr;
			const struct can_frame *cf = &p->rx_cf[i];
			int64_t t_ns = rx_ancillary(bus, p, mh, offset_ns, mono_now_ns);
			struct rmd_bus_rx *rx;

			if (p->rx_msg[i].msg_len != sizeof(*cf) || (mh->msg_flags & MSG_TRUNC)) {
				bus->stats.rx_errors++;
				continue;
			}
			if (cf->can_id & CAN_ERR_FLAG) {
				rmd_socketcan_error_frame(bus, &p->errs, cf);
				continue;
			}
			/*
			 * The filters admit neither, but a sniffer or a future
			 * filter might.  Standard data frames of any DLC pass:
			 * the codec rejects DLC != 8 with the motor's id in hand.
			 */
			if ((cf->can_id & (CAN_EFF_FLAG | CAN_RTR_FLAG)) ||
			    cf->len > CAN_MAX_DLEN) {
				bus->stats.rx_errors++;
				continue;
			}
			rx = &out[count++];
			memset(&rx->f, 0, sizeof(rx->f));
			rx->f.can_id = cf->can_id & CAN_SFF_MASK;
			rx->f.len = cf->len;
			memcpy(rx->f.data, cf->data, cf->len);
			rx->t_ns = t_ns;
			rmd_bus_stamp_seen(&bus->stats, &p->last_rx_ns, t_ns, p->stamp_gap_ns);
			bus->stats.rx_frames++;
			heard(bus, p);
		}
		if ((unsigned)r < want)
			break; /* drained */
	}
	return (int)count;
}

/* rt-safe */
static int socketcan_fd(const struct rmd_bus *bus)
{
	const struct socketcan *p = bus->priv;

	return p ? p->fd : -1;
}

/* The attribute `type` among the rtattrs at a (len bytes), or NULL. */
static const struct rtattr *rta_find(const struct rtattr *a, int len, unsigned short type)
{
	for (; RTA_OK(a, len); a = RTA_NEXT(a, len))
		if (a->rta_type == type)
			return a;
	return NULL;
}

/*
 * The interface's bit rate as the kernel has it (rtnetlink RTM_GETLINK:
 * IFLA_LINKINFO / IFLA_INFO_DATA / IFLA_CAN_BITTIMING, what `ip -details
 * link show` prints), for callers that count wire time (rmdctl rtt); 0
 * when there is none (vcan, vxcan) or the kernel does not say.  Non-rt.
 */
static uint32_t link_bitrate(unsigned ifindex)
{
	struct {
		struct nlmsghdr nh;
		struct ifinfomsg ifi;
	} req = {
		.nh = { .nlmsg_len = NLMSG_LENGTH(sizeof(struct ifinfomsg)),
			.nlmsg_type = RTM_GETLINK,
			.nlmsg_flags = NLM_F_REQUEST },
		.ifi = { .ifi_family = AF_UNSPEC, .ifi_index = (int)ifindex },
	};
	union {
		struct nlmsghdr nh;
		char buf[8192];
	} rep;
	const struct nlmsghdr *nh = &rep.nh;
	const struct rtattr *info, *data, *bt;
	struct can_bittiming cbt;
	uint32_t bitrate = 0;
	ssize_t n;
	int len, fd = socket(AF_NETLINK, SOCK_RAW | SOCK_CLOEXEC, NETLINK_ROUTE);

	if (fd < 0)
		return 0;
	if (send(fd, &req, req.nh.nlmsg_len, 0) < 0)
		goto out;
	n = recv(fd, &rep, sizeof(rep), 0);
	if (n < (ssize_t)NLMSG_LENGTH(sizeof(struct ifinfomsg)) || !NLMSG_OK(nh, (unsigned)n) ||
	    nh->nlmsg_type != RTM_NEWLINK)
		goto out;
	len = (int)(nh->nlmsg_len - NLMSG_LENGTH(sizeof(struct ifinfomsg)));
	info = rta_find(IFLA_RTA((const struct ifinfomsg *)NLMSG_DATA(nh)), len, IFLA_LINKINFO);
	if (!info)
		goto out;
	data = rta_find(RTA_DATA(info), (int)RTA_PAYLOAD(info), IFLA_INFO_DATA);
	if (!data)
		goto out;
	bt = rta_find(RTA_DATA(data), (int)RTA_PAYLOAD(data), IFLA_CAN_BITTIMING);
	if (bt && RTA_PAYLOAD(bt) >= sizeof(cbt)) {
		memcpy(&cbt, RTA_DATA(bt), sizeof(cbt));
		bitrate = cbt.bitrate;
	}
out:
	close(fd);
	return bitrate;
}

/* non-rt */
static void socketcan_close(struct rmd_bus *bus)
{
	struct socketcan *p = bus->priv;

	if (p) {
		if (p->fd >= 0)
			close(p->fd);
		free(p);
	}
	memset(bus, 0, sizeof(*bus));
}

/*
 * Restart the interface (rmd/bus_socketcan.h "No acknowledgement"): down
 * drops the queue and what the controller held, up starts the controller
 * afresh, error-active; nobody acknowledged yet, so no_ack stays.  The
 * socket stays bound (only an unregistered device unbinds it); the
 * ENETDOWN the kernel left on it for the down is taken.  Blocks for the
 * restart (a RCU grace period, the driver's close and open); -EPERM
 * without CAP_NET_ADMIN, the interface untouched.
 */
static int socketcan_flush(struct rmd_bus *bus)
{
	struct socketcan *p = bus->priv;
	struct ifreq ifr;
	socklen_t len = sizeof(int);
	int soerr;

	memset(&ifr, 0, sizeof(ifr));
	memcpy(ifr.ifr_name, p->ifname, sizeof(ifr.ifr_name));
	if (ioctl(p->fd, SIOCGIFFLAGS, &ifr) < 0)
		return -errno;
	if (!(ifr.ifr_flags & IFF_UP))
		return 0; /* down already: the kernel holds nothing for it */
	ifr.ifr_flags = (short)(ifr.ifr_flags & ~IFF_UP);
	if (ioctl(p->fd, SIOCSIFFLAGS, &ifr) < 0)
		return -errno;
	ifr.ifr_flags = (short)(ifr.ifr_flags | IFF_UP);
	if (ioctl(p->fd, SIOCSIFFLAGS, &ifr) < 0)
		return -errno;
	(void)getsockopt(p->fd, SOL_SOCKET, SO_ERROR, &soerr, &len);
	p->errs.ctrl = RMD_BUS_ACTIVE;
	p->errs.tx_passive = false;
	p->errs.ack_errors = 0;
	fold_state(bus, &p->errs);
	return 0;
}

static const struct rmd_bus_ops socketcan_ops = RMD_BUS_OPS_FLUSH(socketcan, rmd_bus_never_due_ns);

void rmd_socketcan_error_frame(struct rmd_bus *bus, struct rmd_socketcan_errs *e,
			       const struct can_frame *cf)
{
	canid_t cls = cf->can_id & CAN_ERR_MASK;
	const uint8_t states = CAN_ERR_CRTL_RX_WARNING | CAN_ERR_CRTL_TX_WARNING |
			       CAN_ERR_CRTL_RX_PASSIVE | CAN_ERR_CRTL_TX_PASSIVE |
			       CAN_ERR_CRTL_ACTIVE;

	bus->stats.bus_errors++;
	/* Least severe first, so the most severe news in one frame wins. */
	if (cls & CAN_ERR_RESTARTED) {
		e->ctrl = RMD_BUS_ACTIVE;
		e->tx_passive = false;
	}
	if ((cls & CAN_ERR_CRTL) && cf->len >= 2 && (cf->data[1] & states)) {
		uint8_t c = cf->data[1];
		bool tx_passive = c & CAN_ERR_CRTL_TX_PASSIVE;

		if (c & (CAN_ERR_CRTL_RX_PASSIVE | CAN_ERR_CRTL_TX_PASSIVE))
			e->ctrl = RMD_BUS_PASSIVE;
		else if (c & (CAN_ERR_CRTL_RX_WARNING | CAN_ERR_CRTL_TX_WARNING))
			e->ctrl = RMD_BUS_WARNING;
		else
			e->ctrl = RMD_BUS_ACTIVE;
		/*
		 * The transmitter left error-passive: its counter fell, so a
		 * frame of ours was acknowledged (a driver reports the larger
		 * of the two sides, so a passive one is always named).
		 */
		if (e->tx_passive && !tx_passive) {
			e->no_ack = false;
			e->ack_errors = 0;
		}
		e->tx_passive = tx_passive;
	}
	if (cls & CAN_ERR_ACK) {
		e->ack_errors++;
		if (e->tx_passive || e->ack_errors >= RMD_SOCKETCAN_NO_ACK_ERRORS)
			e->no_ack = true;
	}
	if (cls & CAN_ERR_BUSOFF)
		e->ctrl = RMD_BUS_OFF;
	fold_state(bus, e);
}

int rmd_socketcan_rcvbuf(const struct rmd_bus *bus)
{
	const struct socketcan *p;

	if (!bus || bus->ops != &socketcan_ops)
		return -EINVAL;
	p = bus->priv;
	return p ? p->rcvbuf : 0;
}

int rmd_socketcan_open(struct rmd_bus *bus, const char *ifname,
		       const struct rmd_socketcan_opts *opts, char *err, size_t errlen)
{
	struct socketcan *p;
	unsigned ifindex;
	bool carrier = true;
	int fd, r, rcvbuf = 0;

	memset(bus, 0, sizeof(*bus));
	if (err && errlen)
		err[0] = '\0';
	if (!ifname || !ifname[0] || strlen(ifname) >= IFNAMSIZ)
		return rmd_errf(err, errlen, -EINVAL,
				"\"%s\": not an interface name (1..%d characters)",
				ifname ? ifname : "(null)", IFNAMSIZ - 1);

	fd = socket(PF_CAN, SOCK_RAW | SOCK_NONBLOCK | SOCK_CLOEXEC, CAN_RAW);
	if (fd < 0) {
		r = -errno;
		if (r == -EAFNOSUPPORT)
			return rmd_errf(
				err, errlen, r,
				"%s: this kernel has no SocketCAN (socket(AF_CAN): %s): run `modprobe can_raw`, or use a kernel built with CONFIG_CAN (tests: tests/vm/vm-run)",
				ifname, strerror(-r));
		if (r == -EPROTONOSUPPORT)
			return rmd_errf(
				err, errlen, r,
				"%s: this kernel has no CAN_RAW protocol (%s): run `modprobe can_raw`",
				ifname, strerror(-r));
		return rmd_errf(err, errlen, r, "%s: socket(AF_CAN): %s", ifname, strerror(-r));
	}

	ifindex = if_nametoindex(ifname);
	if (ifindex == 0) {
		r = -errno;
		if (r == -ENODEV || r == -ENXIO)
			r = rmd_errf(err, errlen, -ENODEV,
				     "%s: no such interface (is the driver loaded? `ip link show`)",
				     ifname);
		else
			r = rmd_errf(err, errlen, r, "%s: if_nametoindex: %s", ifname,
				     strerror(-r));
		goto err_close_socket;
	}
	r = check_interface(fd, ifname, opts, &carrier, err, errlen);
	if (r < 0)
		goto err_close_socket;
	r = setup_socket(fd, ifname, ifindex, opts, &rcvbuf, err, errlen);
	if (r < 0)
		goto err_close_socket;

	p = calloc(1, sizeof(*p));
	if (!p) {
		r = rmd_errf(err, errlen, -ENOMEM, "%s: out of memory", ifname);
		goto err_close_socket;
	}
	p->fd = fd;
	memcpy(p->ifname, ifname, strlen(ifname) + 1);
	p->errs.ctrl = carrier ? RMD_BUS_ACTIVE : RMD_BUS_OFF;
	p->rcvbuf = rcvbuf;
	init_batches(p);

	bus->ops = &socketcan_ops;
	snprintf(bus->name, sizeof(bus->name), "%s", ifname);
	/* Full duplex: requests and replies overlap; the caller picks its timeout. */
	bus->caps = (struct rmd_bus_caps){ .request_spacing_ns = RMD_BUS_CAN_SPACING_NS,
					   .bitrate = link_bitrate(ifindex) };
	bus->state = carrier ? RMD_BUS_ACTIVE : RMD_BUS_OFF;
	bus->priv = p;
	p->stamp_gap_ns = rmd_bus_stamp_gap_ns(bus->caps.bitrate);
	return 0;

err_close_socket:
	close(fd);
	return r;
}
