/* SPDX-License-Identifier: MIT */
/*
 * Wire time of classical CAN 2.0A data frames (11-bit identifier), for the
 * simulated bus (layer 3) and the cycle planner (layer 4).
 *
 * Pure functions, no state: every function here is rt-safe.
 *
 * A frame on the wire, in bits (ISO 11898-1, base format, data frame):
 *
 *   SOF 1 | identifier 11 | RTR 1 | IDE 1 | r0 1 | DLC 4 | data 8n |
 *   CRC sequence 15 | CRC delimiter 1 | ACK slot 1 | ACK delimiter 1 |
 *   EOF 7 | interframe space (intermission) 3
 *
 * The 34 + 8n bits from SOF to the end of the CRC sequence are subject to
 * bit stuffing: after five consecutive bits of equal value the transmitter
 * inserts one bit of the opposite value, and that stuff bit counts as the
 * first bit of the next run.  The remaining 13 bits (delimiters, ACK, EOF,
 * IFS) have a fixed form and are never stuffed.
 *
 *   unstuffed:  34 + 8n + 13 = 47 + 8n bits          (n = 8: 111)
 *   worst case: 47 + 8n + floor((34 + 8n - 1) / 4)   (n = 8: 111 + 24 = 135)
 *
 * The worst case: the first stuff bit needs five equal bits, and since a
 * stuff bit starts the next run, every further one needs only four more
 * bits of the stream; k stuff bits thus need 5 + 4(k - 1) <= 34 + 8n, i.e.
 * k <= (34 + 8n - 1) / 4.  (A bound of floor((34 + 8n) / 5) is too low: it
 * forgets that stuff bits count toward the next run.  The formula above is
 * the one the CAN schedulability literature uses, e.g. Davis et al., "CAN
 * schedulability analysis: refuted, revisited and revised", 2007.)  It is
 * an upper bound: the fixed RTR/IDE/r0 bits and the CRC decide how close a
 * real frame comes to it (the longest 8-byte frame tests/unit/test_can_timing.c
 * finds is 03E#3C3C3C3C3C3C3C1B, 132 bits), but a budget must not bet on
 * the CRC.  Those are docs/design.md's 111 and 135 bits:
 * 111-135 us per 8-byte frame at 1 Mbit/s, so 7 frames fit in 1 ms.
 */
#ifndef RMD_CAN_TIMING_H
#define RMD_CAN_TIMING_H

#include <stdint.h>

#include "rmd/frame.h"

/* Bits from SOF to the end of the CRC sequence without data: stuffed. */
#define RMD_CAN_STUFFED_HDR_BITS 34u
/* CRC delimiter, ACK slot, ACK delimiter, EOF (7): never stuffed. */
#define RMD_CAN_TRAILER_BITS 10u
/* Interframe space (intermission) before the next SOF. */
#define RMD_CAN_IFS_BITS 3u
/* ISO 11898-1 CRC-15 generator x^15+x^14+x^10+x^8+x^7+x^4+x^3+1. */
#define RMD_CAN_CRC15_POLY 0x4599u

/*
 * Data bytes a frame carries on the wire: its len, 8 for a len of 9..15
 * (classical CAN sends 8 bytes for those DLC codes).
 */
unsigned rmd_can_data_bytes(const struct rmd_frame *f);

/*
 * CRC-15 of the frame's unstuffed bits from SOF to the last data bit, as
 * the CRC sequence sends it (MSB first).  The identifier is the low 11 bits
 * of f->can_id, the DLC field the low 4 bits of f->len.  rt-safe.
 */
uint16_t rmd_can_crc15(const struct rmd_frame *f);

/* Stuff bits the frame's actual bits need (SOF .. CRC sequence).  rt-safe. */
unsigned rmd_can_stuff_bits(const struct rmd_frame *f);

/*
 * Exact length in bits of the frame on the wire, stuff bits and the 3-bit
 * interframe space included: 47 + 8n + rmd_can_stuff_bits(f).  rt-safe.
 */
unsigned rmd_can_frame_bits(const struct rmd_frame *f);

/* Length without stuff bits, IFS included: 47 + 8n (dlc > 8 counts as 8).  rt-safe. */
unsigned rmd_can_frame_bits_min(unsigned dlc);

/*
 * Upper bound of the length with worst-case stuffing, IFS included:
 * 47 + 8n + floor((33 + 8n) / 4) (see the top of this file).  This is the
 * figure a schedule must budget.  rt-safe.
 */
unsigned rmd_can_frame_bits_worst(unsigned dlc);

/*
 * Time `bits` bit times take at `bitrate` bit/s, in ns, rounded up.
 * Returns 0 for a bitrate of 0.  rt-safe.
 */
int64_t rmd_can_wire_ns(unsigned bits, uint32_t bitrate);

#endif /* RMD_CAN_TIMING_H */
