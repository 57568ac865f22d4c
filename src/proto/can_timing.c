// SPDX-License-Identifier: MIT
/*
 * Wire time of classical CAN 2.0A data frames: the frame's bits are walked
 * once, in the order the transmitter sends them, through a CRC-15 register
 * and a run-length counter that inserts stuff bits as ISO 11898-1 does.
 * Pure and rt-safe.
 */
#include "rmd/can_timing.h"

/* The bit stream from SOF to the end of the CRC sequence, being stuffed. */
struct stuffer {
	uint16_t crc;	/* CRC-15 register, over SOF .. data */
	unsigned last;	/* value of the previous transmitted bit */
	unsigned run;	/* equal bits in a row, stuff bits included */
	unsigned stuff; /* stuff bits inserted so far */
};

/* One bit through the CRC register (ISO 11898-1 CRC procedure). */
static void crc_bit(struct stuffer *s, unsigned bit)
{
	unsigned nxt = bit ^ ((s->crc >> 14) & 1u);

	s->crc = (uint16_t)((s->crc << 1) & 0x7FFFu);
	if (nxt)
		s->crc ^= RMD_CAN_CRC15_POLY;
}

/* One bit onto the wire; a stuff bit follows five equal bits. */
static void wire_bit(struct stuffer *s, unsigned bit)
{
	if (s->run > 0 && bit == s->last) {
		s->run++;
	} else {
		s->last = bit;
		s->run = 1;
	}
	if (s->run == 5) {
		/* The stuff bit is the opposite value and starts a new run. */
		s->stuff++;
		s->last = !bit;
		s->run = 1;
	}
}

/* `n` bits of `v`, most significant first, into CRC and wire. */
static void put_bits(struct stuffer *s, uint32_t v, unsigned n, int with_crc)
{
	while (n--) {
		unsigned bit = (v >> n) & 1u;

		if (with_crc)
			crc_bit(s, bit);
		wire_bit(s, bit);
	}
}

unsigned rmd_can_data_bytes(const struct rmd_frame *f)
{
	return f->len > RMD_FRAME_LEN ? RMD_FRAME_LEN : f->len;
}

/* SOF .. last data bit: feeds CRC and stuffing alike. */
static void put_header_and_data(struct stuffer *s, const struct rmd_frame *f)
{
	unsigned n = rmd_can_data_bytes(f);

	put_bits(s, 0, 1, 1);			    /* SOF, dominant */
	put_bits(s, f->can_id & 0x7FFu, 11, 1);	    /* identifier */
	put_bits(s, 0, 3, 1);			    /* RTR, IDE, r0: dominant */
	put_bits(s, (uint32_t)f->len & 0xFu, 4, 1); /* DLC */
	for (unsigned i = 0; i < n; i++)
		put_bits(s, f->data[i], 8, 1);
}

uint16_t rmd_can_crc15(const struct rmd_frame *f)
{
	struct stuffer s = { 0 };

	put_header_and_data(&s, f);
	return s.crc;
}

unsigned rmd_can_stuff_bits(const struct rmd_frame *f)
{
	struct stuffer s = { 0 };

	put_header_and_data(&s, f);
	put_bits(&s, s.crc, 15, 0); /* the CRC sequence is stuffed too */
	return s.stuff;
}

unsigned rmd_can_frame_bits_min(unsigned dlc)
{
	unsigned n = dlc > RMD_FRAME_LEN ? RMD_FRAME_LEN : dlc;

	return RMD_CAN_STUFFED_HDR_BITS + 8u * n + RMD_CAN_TRAILER_BITS + RMD_CAN_IFS_BITS;
}

unsigned rmd_can_frame_bits(const struct rmd_frame *f)
{
	return rmd_can_frame_bits_min(rmd_can_data_bytes(f)) + rmd_can_stuff_bits(f);
}

unsigned rmd_can_frame_bits_worst(unsigned dlc)
{
	unsigned n = dlc > RMD_FRAME_LEN ? RMD_FRAME_LEN : dlc;
	unsigned stuffed = RMD_CAN_STUFFED_HDR_BITS + 8u * n;

	return rmd_can_frame_bits_min(n) + (stuffed - 1u) / 4u;
}

int64_t rmd_can_wire_ns(unsigned bits, uint32_t bitrate)
{
	if (bitrate == 0)
		return 0;
	return ((int64_t)bits * 1000000000 + (int64_t)bitrate - 1) / (int64_t)bitrate;
}
