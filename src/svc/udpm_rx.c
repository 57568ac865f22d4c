// SPDX-License-Identifier: MIT
/*
 * LCM's udpm wire format, received: see rmd/udpm_rx.h.
 *
 * Where this is stricter than LCM 1.3's receiver (lcm/lcm_udpm.c): LCM
 * counts fragments down, so a repeated one completes a message with a hole
 * (bytes of an earlier message, or of none); here a message is whole only
 * when every fragment number up to its count came once and, in number
 * order, their bytes tile the message's size exactly.  LCM drops fragments
 * that come before the first one; here any order goes together.
 */
#include <string.h>

#include "rmd/udpm_rx.h"

static const char *const verdict_names[RMD_UDPM_VERDICTS] = {
	[RMD_UDPM_MESSAGE] = "message",	    [RMD_UDPM_PENDING] = "pending",
	[RMD_UDPM_BAD_MAGIC] = "bad-magic", [RMD_UDPM_BAD_CHANNEL] = "bad-channel",
	[RMD_UDPM_TOO_LONG] = "too-long",   [RMD_UDPM_BAD_FRAGMENT] = "bad-fragment",
	[RMD_UDPM_DUPLICATE] = "duplicate", [RMD_UDPM_HOLES] = "holes",
};

const char *rmd_udpm_verdict_name(enum rmd_udpm_verdict v)
{
	return (unsigned)v < RMD_UDPM_VERDICTS ? verdict_names[v] : "?";
}

void rmd_udpm_rx_init(struct rmd_udpm_rx *rx)
{
	rx->touch = 0;
	rx->abandoned = 0;
	memset(rx->n, 0, sizeof(rx->n));
	for (unsigned k = 0; k < RMD_UDPM_SLOTS; k++)
		rx->slot[k].used = false;
}

static uint32_t be32(const unsigned char *p)
{
	return (uint32_t)p[0] << 24 | (uint32_t)p[1] << 16 | (uint32_t)p[2] << 8 | p[3];
}

static uint16_t be16(const unsigned char *p)
{
	return (uint16_t)(p[0] << 8 | p[1]);
}

static void put32(unsigned char *p, uint32_t v)
{
	p[0] = (unsigned char)(v >> 24);
	p[1] = (unsigned char)(v >> 16);
	p[2] = (unsigned char)(v >> 8);
	p[3] = (unsigned char)v;
}

void rmd_udpm_put_short_header(unsigned char *p, uint32_t seqno)
{
	put32(p, RMD_UDPM_MAGIC_SHORT);
	put32(p + 4, seqno);
}

void rmd_udpm_put_fragment_header(unsigned char *p, uint32_t seqno, uint32_t size, uint32_t off,
				  uint16_t no, uint16_t count)
{
	put32(p, RMD_UDPM_MAGIC_LONG);
	put32(p + 4, seqno);
	put32(p + 8, size);
	put32(p + 12, off);
	p[16] = (unsigned char)(no >> 8);
	p[17] = (unsigned char)no;
	p[18] = (unsigned char)(count >> 8);
	p[19] = (unsigned char)count;
}

/* The channel at the front of p[0..len): its length, or -1 without a NUL or too long. */
static int channel_len(const unsigned char *p, size_t len)
{
	size_t cl = strnlen((const char *)p, len);

	return cl == len || cl > RMD_UDPM_CHANNEL_MAX ? -1 : (int)cl;
}

/*
 * The slot for message (from, seqno) of `size` bytes: the one that has it;
 * else the sender's own (LCM sends a message's fragments back to back, so
 * an unfinished one of the same sender is lost); else a free one; else the
 * one touched longest ago.  A slot given to a new message starts empty.
 */
static struct rmd_udpm_slot *slot_for(struct rmd_udpm_rx *rx, uint32_t addr, uint16_t port,
				      uint32_t seqno, uint32_t size, uint16_t count)
{
	struct rmd_udpm_slot *s, *own = NULL, *free_ = NULL, *oldest = NULL, *pick;

	for (s = rx->slot; s < rx->slot + RMD_UDPM_SLOTS; s++) {
		if (!s->used) {
			free_ = free_ ? free_ : s;
			continue;
		}
		if (s->from_addr == addr && s->from_port == port) {
			if (s->seqno == seqno && s->size == size)
				return s;
			own = s;
		}
		if (!oldest || s->touch < oldest->touch)
			oldest = s;
	}
	pick = own ? own : free_ ? free_ : oldest;
	if (pick->used)
		rx->abandoned++;
	/* field by field: the 64 KiB of data need no clearing, the tiling check covers them */
	pick->used = true;
	pick->from_addr = addr;
	pick->from_port = port;
	pick->seqno = seqno;
	pick->size = size;
	pick->count = count;
	pick->have = 0;
	pick->channel[0] = '\0';
	return pick;
}

/* Do the fragments, in number order, cover [0, size) exactly once? */
static bool tiled(const struct rmd_udpm_slot *s)
{
	uint64_t at = 0;

	for (unsigned k = 0; k < s->count; k++) {
		if (s->off[k] != at)
			return false;
		at += s->len[k];
	}
	return at == s->size;
}

static enum rmd_udpm_verdict fragment(struct rmd_udpm_rx *rx, uint32_t addr, uint16_t port,
				      const unsigned char *p, size_t n, struct rmd_udpm_msg *out)
{
	uint32_t seqno = be32(p + 4), size = be32(p + 8), off = be32(p + 12);
	uint16_t no = be16(p + 16), count = be16(p + 18);
	const unsigned char *d = p + RMD_UDPM_LONG_HDR;
	size_t len = n - RMD_UDPM_LONG_HDR;
	const char *channel = NULL;
	struct rmd_udpm_slot *s;
	uint64_t all;

	if (no == 0) {
		int cl = channel_len(d, len);

		if (cl < 0)
			return RMD_UDPM_BAD_CHANNEL;
		channel = (const char *)d;
		d += cl + 1;
		len -= (size_t)cl + 1;
	}
	if (size > RMD_UDPM_MSG_MAX) {
		out->channel = channel ? channel : "";
		out->size = size;
		return RMD_UDPM_TOO_LONG;
	}
	if (!count || count > RMD_UDPM_FRAGS_MAX || no >= count || (uint64_t)off + len > size)
		return RMD_UDPM_BAD_FRAGMENT;
	s = slot_for(rx, addr, port, seqno, size, count);
	if (s->count != count)
		return RMD_UDPM_BAD_FRAGMENT;
	if (s->have & (uint64_t)1 << no)
		return RMD_UDPM_DUPLICATE;
	if (channel)
		memcpy(s->channel, channel, (size_t)(d - (const unsigned char *)channel));
	memcpy(s->data + off, d, len);
	s->off[no] = off;
	s->len[no] = (uint32_t)len;
	s->have |= (uint64_t)1 << no;
	s->touch = ++rx->touch;
	all = count == 64 ? ~(uint64_t)0 : ((uint64_t)1 << count) - 1;
	if (s->have != all)
		return RMD_UDPM_PENDING;
	s->used = false;
	if (!tiled(s))
		return RMD_UDPM_HOLES;
	*out = (struct rmd_udpm_msg){ .channel = s->channel, .data = s->data, .size = s->size };
	return RMD_UDPM_MESSAGE;
}

static enum rmd_udpm_verdict packet(struct rmd_udpm_rx *rx, uint32_t addr, uint16_t port,
				    const unsigned char *p, size_t n, struct rmd_udpm_msg *out)
{
	int cl;

	if (n > RMD_UDPM_PKT_MAX)
		return RMD_UDPM_TOO_LONG;
	if (n >= RMD_UDPM_LONG_HDR && be32(p) == RMD_UDPM_MAGIC_LONG)
		return fragment(rx, addr, port, p, n, out);
	if (n < RMD_UDPM_SHORT_HDR || be32(p) != RMD_UDPM_MAGIC_SHORT)
		return RMD_UDPM_BAD_MAGIC;
	cl = channel_len(p + RMD_UDPM_SHORT_HDR, n - RMD_UDPM_SHORT_HDR);
	if (cl < 0)
		return RMD_UDPM_BAD_CHANNEL;
	*out = (struct rmd_udpm_msg){
		.channel = (const char *)p + RMD_UDPM_SHORT_HDR,
		.data = p + RMD_UDPM_SHORT_HDR + cl + 1,
		.size = (uint32_t)(n - RMD_UDPM_SHORT_HDR - (size_t)cl - 1),
	};
	return RMD_UDPM_MESSAGE;
}

enum rmd_udpm_verdict rmd_udpm_rx_packet(struct rmd_udpm_rx *rx, uint32_t from_addr,
					 uint16_t from_port, const unsigned char *pkt, size_t len,
					 struct rmd_udpm_msg *out)
{
	enum rmd_udpm_verdict v;

	out->channel = "";
	out->data = NULL;
	out->size = 0;
	v = packet(rx, from_addr, from_port, pkt, len, out);
	rx->n[v]++;
	return v;
}
