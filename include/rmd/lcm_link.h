/* SPDX-License-Identifier: MIT */
/*
 * The LCM link (docs/design.md, layer svc): rmdd's one door to LCM.  It
 * moves whole messages, (channel, bytes), and says when each arrived; what
 * a message means is the caller's (the bridge).
 *
 * udpm:// (LCM's UDP multicast): the link speaks the wire format itself,
 * the one LCM 1.3 and 1.5 share (lcm/lcm_udpm.c; rmd/udpm_rx.h): one
 * socket in the group, read in the caller's thread with the kernel's
 * receive stamp, fragments put together by rmd/udpm_rx.h; one socket that
 * sends, a message as one "LC02" datagram when channel and bytes fit
 * LCM_SHORT_MESSAGE_MAX_SIZE, else as "LC03" fragments cut as
 * lcm_udpm_publish() cuts them.  Both sockets are the link's, so the
 * receive socket's filter, which drops the datagrams the link sent (the
 * kernel loops multicast back to the host), names its address and port
 * without asking LCM anything.  liblcm is not used on udpm://: no LCM
 * internal (its threads, its descriptors) can change under the link.
 *
 * Any other provider (memq://, file://, tcpq://): LCM's own path,
 * lcm_subscribe(), lcm_handle() in the caller's thread and lcm_publish();
 * the threads LCM starts meanwhile are found (by comparing
 * /proc/self/task before and after) and raised with the caller
 * (rmd_lcm_link_raise()).
 *
 * rmd_lcm_link_info() says which protections are in place and why not:
 * the caller logs it at start.  One thread at a time uses a link (the
 * bridge's), except rmd_lcm_link_info(), which any thread may call.
 */
#ifndef RMD_LCM_LINK_H
#define RMD_LCM_LINK_H

#include <stdbool.h>
#include <stddef.h>
#include <stdint.h>

#include "rmd/udpm_rx.h"

/* LCM 1.3 and 1.5 on Linux (lcm/udpm_util.h): the longest short message (channel, NUL and
 * bytes) and the room in each fragment. */
#define RMD_LCM_LINK_SHORT_MAX 65499
#define RMD_LCM_LINK_FRAGMENT_MAX 65487
/* LCM's own threads (other providers) the link finds and raises, at most. */
#define RMD_LCM_LINK_THREADS 4

struct rmd_lcm_link;

struct rmd_lcm_link_opts {
	const char *url; /* an LCM URL */
	/* only messages on channels that start with it are received; "" or NULL: every one */
	const char *prefix;
	/* and those that start with this one too (the robot's channels); NULL or "": none */
	const char *prefix2;
	/* udpm: receive buffer asked of the kernel when the URL names no recv_buf_size; 0: none */
	int recv_buf_size;
	/* other providers: messages LCM queues before it drops (its default: 30); 0: LCM's */
	unsigned queue;
};

/* A message that arrived: valid until the next rmd_lcm_link_receive(). */
struct rmd_lcm_msg {
	const char *channel; /* NUL-terminated; "" when a too-long message's datagram named none */
	const unsigned char *data; /* NULL: too long to keep (rmd_lcm_link_receive: -EMSGSIZE) */
	uint32_t size;
	/* when it arrived, CLOCK_REALTIME ns: udpm, the kernel's stamp of its last datagram;
	 * others, LCM's recv_utime; 0: none (then: when it was read) */
	int64_t rx_real_ns;
};

/* What is in place, and why not; counters since rmd_lcm_link_new(). */
struct rmd_lcm_link_info {
	bool udpm; /* the link reads and writes the group itself (else LCM's provider) */
	/* udpm: the datagrams the link sent are dropped by the receive socket's filter;
	 * else filter_error is -errno of the refused filter (they are read and dropped) */
	bool filter;
	int filter_error;
	/* udpm: the kernel stamps each datagram; else stamps_error (arrival = when read) */
	bool stamps;
	int stamps_error;
	int rcvbuf;		 /* udpm: the receive buffer the kernel granted, bytes */
	unsigned lcm_threads;	 /* other providers: threads LCM started, found */
	unsigned lcm_threads_rt; /* of which rmd_lcm_link_raise() raised */
	uint64_t datagrams;	 /* udpm: datagrams read */
	uint64_t own_read;	 /* udpm: of which the link's own, read back (no filter) */
	uint64_t published;	 /* messages sent */
};

/*
 * Open the link for opts->url: 0 and *out, or -EINVAL (a bad URL or
 * option) / -EIO (the provider could not be created, or joined: no route
 * for multicast, say), with the reason in err.  Non-rt.
 */
int rmd_lcm_link_new(struct rmd_lcm_link **out, const struct rmd_lcm_link_opts *opts, char *err,
		     size_t errlen);

/* Close it; NULL is a no-op.  Non-rt. */
void rmd_lcm_link_free(struct rmd_lcm_link *l);

/* The descriptor that turns readable when a message may be waiting (poll/epoll).  Non-rt. */
int rmd_lcm_link_fd(const struct rmd_lcm_link *l);

/*
 * Take what waits, without blocking: 1 and *m, a message; 0, something was
 * read that is no message for the caller (a fragment kept, a datagram
 * dropped, a channel outside the prefix, the link's own datagram);
 * -EMSGSIZE, a message too long to keep (*m: its channel and size, data
 * NULL); -EAGAIN, nothing waits; another -errno, the receive failed.  On
 * udpm one datagram a call, bounded time, no allocation: rt-safe (the
 * bridge's thread runs it at SCHED_FIFO).  Other providers: LCM's handle,
 * which allocates.
 */
int rmd_lcm_link_receive(struct rmd_lcm_link *l, struct rmd_lcm_msg *m);

/*
 * Send size bytes on channel: 0, or -EINVAL (a channel longer than
 * RMD_UDPM_CHANNEL_MAX, or more than 65535 fragments) or the -errno of the
 * send.  udpm: no allocation, one sendmsg() a datagram, blocking as LCM's
 * does when the socket's send buffer is full.  Non-rt.
 */
int rmd_lcm_link_publish(struct rmd_lcm_link *l, const char *channel, const void *data,
			 size_t size);

/*
 * The threads LCM started for the link (other providers; udpm has none)
 * to SCHED_FIFO rt_priority (0: left as they are): the number raised, or
 * the -errno of the first refusal.  Non-rt.
 */
int rmd_lcm_link_raise(struct rmd_lcm_link *l, unsigned rt_priority);

/* What is in place, and the counters.  Any thread.  Non-rt (but lock-free). */
void rmd_lcm_link_info(const struct rmd_lcm_link *l, struct rmd_lcm_link_info *info);

#endif /* RMD_LCM_LINK_H */
