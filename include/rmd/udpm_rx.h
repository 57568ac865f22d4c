/* SPDX-License-Identifier: MIT */
/*
 * LCM's udpm wire format, received: datagrams in, whole messages out.
 *
 * LCM 1.3 (lcm/lcm_udpm.c) sends a message that fits one datagram as
 * "LC02", a sequence number, the channel and its NUL, the payload; a longer
 * one as fragments "LC03", sequence number, message size, fragment offset,
 * fragment number and count, then (first fragment only) the channel and its
 * NUL, then that fragment's bytes; all big-endian.  This module checks every
 * field of such a datagram (it comes from the network: anyone on the group
 * may send anything) and puts fragments together in a fixed number of
 * slots, one a sender.  It allocates nothing, logs nothing and reads no
 * clock: the caller owns the socket and decides what a message means.
 */
#ifndef RMD_UDPM_RX_H
#define RMD_UDPM_RX_H

#include <stdbool.h>
#include <stddef.h>
#include <stdint.h>

#define RMD_UDPM_MAGIC_SHORT 0x4c433032u /* "LC02" */
#define RMD_UDPM_MAGIC_LONG 0x4c433033u	 /* "LC03" */
#define RMD_UDPM_SHORT_HDR 8
#define RMD_UDPM_LONG_HDR 20
/* A channel name's longest (LCM_MAX_CHANNEL_NAME_LENGTH), without its NUL. */
#define RMD_UDPM_CHANNEL_MAX 63
/* The largest datagram read, and the largest message put together (rmd's are under 3 KiB). */
#define RMD_UDPM_PKT_MAX 65536
#define RMD_UDPM_MSG_MAX 65536
/* Messages put together at once (one a sender is usual), and fragments in one at most: LCM
 * sends ~64 KiB a fragment (1423 bytes on macOS, 47 fragments for the largest message). */
#define RMD_UDPM_SLOTS 4
#define RMD_UDPM_FRAGS_MAX 64

/* What became of one datagram (rmd_udpm_rx_packet()); each is counted in rx->n[]. */
enum rmd_udpm_verdict {
	/* a whole message: in *out */
	RMD_UDPM_MESSAGE,
	/* a fragment, kept: its message is not whole yet */
	RMD_UDPM_PENDING,
	/* neither LC02 nor LC03, or shorter than its header */
	RMD_UDPM_BAD_MAGIC,
	/* no NUL inside the datagram, or longer than RMD_UDPM_CHANNEL_MAX */
	RMD_UDPM_BAD_CHANNEL,
	/* a message over RMD_UDPM_MSG_MAX: out->size says how long, out->channel is its
	 * channel if this datagram named it */
	RMD_UDPM_TOO_LONG,
	/* count 0 or over RMD_UDPM_FRAGS_MAX, number past the count, bytes past the size,
	 * or a count other than its message's */
	RMD_UDPM_BAD_FRAGMENT,
	/* a fragment number its message already has */
	RMD_UDPM_DUPLICATE,
	/* every fragment came but they do not tile the size exactly: the message is dropped */
	RMD_UDPM_HOLES,
	RMD_UDPM_VERDICTS,
};

/* A whole message: valid until the next rmd_udpm_rx_packet() on the same rx or datagram. */
struct rmd_udpm_msg {
	const char *channel; /* NUL-terminated, at most RMD_UDPM_CHANNEL_MAX characters */
	const unsigned char *data;
	uint32_t size; /* at most RMD_UDPM_MSG_MAX */
};

/* A message being put together. */
struct rmd_udpm_slot {
	bool used;
	uint32_t from_addr, seqno, size;
	uint16_t from_port, count;
	uint64_t have;	/* fragment numbers received, a bit each */
	uint64_t touch; /* rx->touch when a fragment last came: the oldest is reused */
	uint32_t off[RMD_UDPM_FRAGS_MAX], len[RMD_UDPM_FRAGS_MAX];
	char channel[RMD_UDPM_CHANNEL_MAX + 1];
	unsigned char data[RMD_UDPM_MSG_MAX];
};

/* The receiver: zero it (or rmd_udpm_rx_init()) before the first datagram; ~260 KiB. */
struct rmd_udpm_rx {
	struct rmd_udpm_slot slot[RMD_UDPM_SLOTS];
	uint64_t touch;
	uint64_t n[RMD_UDPM_VERDICTS]; /* datagrams, by verdict */
	uint64_t abandoned; /* messages given up unfinished: their slot went to a newer one */
};

/* Forget every message in progress and every count.  rt-safe. */
void rmd_udpm_rx_init(struct rmd_udpm_rx *rx);

/*
 * One datagram of `len` bytes from (from_addr, from_port) (any values that
 * tell senders apart, e.g. sockaddr_in's): RMD_UDPM_MESSAGE with *out set
 * when it completes a message, else another verdict (out->channel is "" and
 * out->data NULL, but see RMD_UDPM_TOO_LONG).  Bounded
 * time (the datagram's length plus RMD_UDPM_SLOTS and RMD_UDPM_FRAGS_MAX
 * steps); no allocation.  rt-safe.
 */
enum rmd_udpm_verdict rmd_udpm_rx_packet(struct rmd_udpm_rx *rx, uint32_t from_addr,
					 uint16_t from_port, const unsigned char *pkt, size_t len,
					 struct rmd_udpm_msg *out);

/*
 * The headers as LCM writes them (big-endian), for tests and tools that
 * send udpm: an LC02 short message's (RMD_UDPM_SHORT_HDR bytes at p), and
 * an LC03 fragment's (RMD_UDPM_LONG_HDR bytes).  rt-safe.
 */
void rmd_udpm_put_short_header(unsigned char *p, uint32_t seqno);
void rmd_udpm_put_fragment_header(unsigned char *p, uint32_t seqno, uint32_t size, uint32_t off,
				  uint16_t no, uint16_t count);

/* "message", "pending", "bad-magic" ...: for logs and tests. */
const char *rmd_udpm_verdict_name(enum rmd_udpm_verdict v);

#endif /* RMD_UDPM_RX_H */
