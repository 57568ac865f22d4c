// SPDX-License-Identifier: MIT
/*
 * rmdctl set-id, set-zero, set-timeout, accel, pid: commands that write a
 * motor's settings (ROM writes ask for confirmation).  Non-rt.
 */
#include <inttypes.h>
#include <math.h>
#include <stdint.h>
#include <stdio.h>
#include <string.h>

#include "rmd/time.h"
#include "rmd/codec.h"
#include "rmd/describe.h"
#include "rmdctl.h"

/* accel: V3 §2.5.1 range */
#define ACCEL_MIN_DPS2 100
#define ACCEL_MAX_DPS2 60000
/* set-id: how long the new id may take to answer */
#define SET_ID_WAIT_NS 1000000000

/* ---- set-id, set-zero, set-timeout ---------------------------------------------------- */

/* After a V3 0x79 with --force: the other motors that took the new id too. */
static int others_renumbered(struct dev *d, const uint8_t *before, unsigned n, uint8_t old_id,
			     uint8_t new_id)
{
	uint8_t others[RMD_MAX_MOTORS], found[RMD_MAX_MOTORS];
	struct req st[RMD_MAX_MOTORS];
	unsigned k = 0;
	int m;

	for (unsigned i = 0; i < n; i++)
		if (before[i] != old_id)
			others[k++] = before[i];
	if (k == 0)
		return RMDCTL_EXIT_OK;
	m = rmdctl_probe(d, others, k, found, st);
	if (m < 0)
		return -m;
	if ((unsigned)m == k)
		return RMDCTL_EXIT_OK;
	for (unsigned i = 0; i < k; i++)
		if (!st[i].ok)
			tool_log(TOOL_LOG_ERR,
				 "%s: motor %u no longer answers: it took id %u too (its CAN-ID "
				 "filter is off)",
				 d->name, others[i], new_id);
	return RMDCTL_EXIT_DATA;
}

/* Until `until`: whether the new id answers 0x9A and the old one no longer does. */
static int moved(struct dev *d, uint8_t old_id, uint8_t new_id, int64_t until, bool *ok)
{
	*ok = false;
	do {
		struct req v[2];
		int r;

		rmdctl_req_init(&v[0], new_id, 0x9A);
		rmdctl_req_init(&v[1], old_id, 0x9A);
		r = rmdctl_run_reqs(d, v, 2);
		if (r)
			return r;
		if (v[0].ok && !v[1].ok) {
			*ok = true;
			return 0;
		}
	} while (rmd_now_ns() < until && !rmdctl_interrupted);
	return 0;
}

/*
 * V4.2 §2.34.4 (RMD_SET_ID_FUNC_20): 0x20 index 5 on the motor's own
 * 0x140 + ID writes the new ID to ROM, a 0x76 reset makes it effective.
 * Firmware 2025070202 echoes the 0x20 from the new 0x240 + ID at once and
 * takes requests on the old one until the reset (docs/protocol-v4.md);
 * no other motor hears it.
 */
static int set_id_func_20(struct dev *d, uint8_t old_id, uint8_t new_id)
{
	const struct rmd_dialect *dl = rmdctl_dialect(d);
	struct rmd_msg msg = { .cmd = 0x20 };
	struct rmd_txn t;
	struct req q;
	bool ok;
	int r;

	r = rmdctl_confirm(d, "write CAN id %u to motor %u on %s (ROM, then a reset)", new_id,
			   old_id, d->name);
	if (r)
		return r;
	rmd_msg_set(&msg, RMD_FLD_INDEX, 5);
	rmd_msg_set(&msg, RMD_FLD_VALUE, new_id);
	r = rmd_txn_prepare(&t, d->proto, old_id, &msg);
	if (r < 0) {
		tool_log(TOOL_LOG_ERR, "motor %u: cannot encode 0x20: %s", old_id, strerror(-r));
		return RMDCTL_EXIT_DATA;
	}
	t.reply_id = dl->reply_base + new_id; /* the echo comes from the new id already */
	r = rmd_txn_run(d->b, &t, 1, &d->txn);
	if (r < 0) {
		tool_log(TOOL_LOG_ERR, "%s: %s", d->name, strerror(-r));
		return RMDCTL_EXIT_DATA;
	}
	if (!t.done || memcmp(t.rep.f.data, t.req.data, RMD_FRAME_LEN)) {
		tool_log(TOOL_LOG_ERR,
			 "%s: motor %u did not echo 0x20 index 5 from 0x%03X (the new id): the id "
			 "may not have changed",
			 d->name, old_id, (unsigned)t.reply_id);
		return RMDCTL_EXIT_DATA;
	}
	/* V4.2 §2.25: the reset that makes the new id the motor's; no answer */
	rmdctl_req_init(&q, old_id, 0x76);
	r = rmdctl_run_reqs(d, &q, 1);
	if (r)
		return r;
	r = moved(d, old_id, new_id, rmd_now_ns() + SET_ID_WAIT_NS, &ok);
	if (r)
		return r;
	if (!ok) {
		tool_log(TOOL_LOG_ERR,
			 "%s: motor %u echoed the new id %u, but after the reset id %u does not "
			 "answer as expected and id %u may still answer",
			 d->name, old_id, new_id, new_id, old_id);
		return RMDCTL_EXIT_DATA;
	}
	printf("%s: motor %u is now motor %u (ROM)\n", d->name, old_id, new_id);
	return RMDCTL_EXIT_OK;
}

int rmdctl_run_set_id(struct dev *d, int argc, char **argv)
{
	uint8_t old_id, new_id, all[RMD_MAX_MOTORS], found[RMD_MAX_MOTORS];
	struct req st[RMD_MAX_MOTORS], q;
	/* V3 §4: 0x79 rides on 0x300, to every motor */
	bool v3 = rmdctl_dialect(d)->set_id == RMD_SET_ID_79_300, old_seen = false,
	     new_seen = false, ok;
	int m, r;

	(void)argc;
	if (rmdctl_parse_id(argv[0], "OLD id", &old_id) < 0 ||
	    rmdctl_parse_id(argv[1], "NEW id", &new_id) < 0)
		return RMDCTL_EXIT_USAGE;
	if (old_id == new_id) {
		tool_log(TOOL_LOG_ERR, "OLD and NEW are both %u", old_id);
		return RMDCTL_EXIT_USAGE;
	}
	r = rmdctl_open_bus_for(d, true, "write CAN id %u to motor %u on %s", new_id, old_id,
				d->bus_spec);
	if (r)
		return r;
	/* Who is on the bus: V3 §4 sends 0x79 on 0x300, and every motor hears it. */
	m = rmdctl_probe(d, all, rmdctl_all_ids(all), found, st);
	if (m < 0) {
		r = -m;
		goto out;
	}
	for (int i = 0; i < m; i++) {
		old_seen |= found[i] == old_id;
		new_seen |= found[i] == new_id;
	}
	r = RMDCTL_EXIT_DATA;
	if (!old_seen) {
		tool_log(TOOL_LOG_ERR, "%s: motor %u does not answer 0x9A: nothing to renumber",
			 d->name, old_id);
		goto out;
	}
	if (new_seen) {
		tool_log(TOOL_LOG_ERR, "%s: id %u is taken: a motor answers on it", d->name,
			 new_id);
		goto out;
	}
	if (rmdctl_dialect(d)->set_id == RMD_SET_ID_FUNC_20) {
		r = set_id_func_20(d, old_id, new_id);
		goto out;
	}
	if (v3) {
		tool_log(TOOL_LOG_ERR,
			 "warning: V3 §4 sends 0x79 on 0x300: every motor on %s whose CAN-ID "
			 "filter is off (0x20 index 2) takes id %u, not only motor %u",
			 d->name, new_id, old_id);
		if (m > 1 && !d->force) {
			tool_log(TOOL_LOG_ERR,
				 "%s: %d motors answer; connect motor %u alone, or turn the "
				 "others' CAN-ID filter on and add --force",
				 d->name, m, old_id);
			goto out;
		}
	}
	r = rmdctl_confirm(d, "write CAN id %u to motor %u on %s (ROM%s)", new_id, old_id, d->name,
			   v3 ? "; every motor with the CAN-ID filter off hears it" : "");
	if (r)
		goto out;
	rmdctl_req_init(&q, old_id, 0x79);
	rmd_msg_set(&q.msg, RMD_FLD_READ_FLAG, 0); /* V3 §4.2 / V2 §3.52: 0 writes */
	rmd_msg_set(&q.msg, RMD_FLD_CAN_ID, new_id);
	r = rmdctl_run_reqs(d, &q, 1);
	if (r)
		goto out;
	/* V3 §4.3: the answer of a write is the request itself (the row's reply layout is a read's). */
	if (!q.answered) {
		rmdctl_report_missing(d, &q, "");
		r = RMDCTL_EXIT_DATA;
		goto out;
	}
	if (memcmp(q.t.rep.f.data, q.t.req.data, RMD_FRAME_LEN)) {
		tool_log(TOOL_LOG_ERR,
			 "%s: the answer to 0x79 is not the echo of the request: the id "
			 "may not have changed",
			 d->name);
		r = RMDCTL_EXIT_DATA;
		goto out;
	}
	/* The new id answers, the old one no longer does. */
	r = moved(d, old_id, new_id, rmd_now_ns() + SET_ID_WAIT_NS, &ok);
	if (r)
		goto out;
	if (ok) {
		printf("%s: motor %u is now motor %u (ROM)\n", d->name, old_id, new_id);
		r = others_renumbered(d, found, (unsigned)m, old_id, new_id);
		goto out;
	}
	tool_log(TOOL_LOG_ERR, "%s: motor %u echoed the new id %u, but id %u %s and id %u %s",
		 d->name, old_id, new_id, new_id, "does not answer as expected", old_id,
		 "may still answer");
	r = RMDCTL_EXIT_DATA;
out:
	rmdctl_close_bus(d);
	return r;
}

int rmdctl_run_set_zero(struct dev *d, int argc, char **argv)
{
	struct req q;
	uint8_t id = d->id;
	int r;

	(void)argc;
	(void)argv;
	r = rmdctl_open_bus_for(d, true, "write the zero of motor %u on %s", id, d->bus_spec);
	if (r)
		return r;
	r = rmdctl_confirm(d, "make the current position of motor %u on %s its zero (ROM)", id,
			   d->name);
	if (r)
		goto out;
	/* V3 §2.10 / V2 §3.25: the current position becomes the zero, in ROM, after a restart. */
	rmdctl_req_init(&q, id, 0x64);
	r = rmdctl_ask(d, &q);
	if (r)
		goto out;
	printf("%s: motor %u: zero offset %" PRId64 " counts written to ROM; it applies after a "
	       "reset (`rmdctl reset %u`) or a power cycle\n",
	       d->name, id, q.rep.v[RMD_FLD_ENCODER_OFF], id);
out:
	rmdctl_close_bus(d);
	return r;
}

int rmdctl_run_set_timeout(struct dev *d, int argc, char **argv)
{
	struct req q;
	uint64_t ms;
	uint8_t id = d->id;
	int r;

	(void)argc;
	if (rmdctl_parse_uint(argv[1], 0, UINT32_MAX, &ms) < 0) {
		tool_log(TOOL_LOG_ERR, "bad MS \"%s\" (0..%" PRIu32 "; 0 turns the protection off)",
			 argv[1], UINT32_MAX);
		return RMDCTL_EXIT_USAGE;
	}
	if (!rmd_dialect_has(rmdctl_dialect(d), RMD_DIALECT_COMM_LOSS_B3)) {
		tool_log(TOOL_LOG_ERR, "protocol %s has no comm-loss protection (0xB3 is V3 §2.30)",
			 rmdctl_dialect(d)->name);
		return RMDCTL_EXIT_USAGE;
	}
	r = rmdctl_open_bus_for(d, true, "write the comm timeout of motor %u on %s", id,
				d->bus_spec);
	if (r)
		return r;
	r = rmdctl_confirm(d,
			   "set the comm-loss protection of motor %u on %s to %" PRIu64 " ms (ROM)",
			   id, d->name, ms);
	if (r)
		goto out;
	/* V3 §2.30: stored in ROM; the answer echoes the request, or (example 2) is zeros. */
	rmdctl_req_init(&q, id, 0xB3);
	rmd_msg_set(&q.msg, RMD_FLD_TIMEOUT, (int64_t)ms);
	r = rmdctl_run_reqs(d, &q, 1);
	if (!r && q.answered && !q.ok && !memcmp(q.t.rep.f.data, "\xB3\0\0\0\0\0\0", 8)) {
		printf("%s: motor %u: comm-loss protection written to ROM; answered with zeros "
		       "(V3 §2.30 example 2): accepted, the time is not verified\n",
		       d->name, id);
		goto out;
	}
	r = r ? r : rmdctl_ask_check(d, &q);
	if (r)
		goto out;
	if (ms)
		printf("%s: motor %u: comm-loss protection %" PRIu64
		       " ms written to ROM, echo verified; the motor turns its output off when it "
		       "hears nothing for %" PRIu64 " ms\n",
		       d->name, id, ms, ms);
	else
		printf("%s: motor %u: comm-loss protection off (ROM), echo verified\n", d->name,
		       id);
out:
	rmdctl_close_bus(d);
	return r;
}

/* ---- accel, pid ----------------------------------------------------------------------- */

static const char *const accel_names[4] = { "position-accel", "position-decel", "speed-accel",
					    "speed-decel" };

int rmdctl_run_accel(struct dev *d, int argc, char **argv)
{
	const struct rmd_cmd_spec *w = rmd_cmd_find(d->proto, 0x43);
	/* V3 §2.5 writes by index; V2 §3.20 writes its one acceleration */
	bool v2 = w && !rmd_layout_field(w, RMD_DIR_REQUEST, RMD_FLD_INDEX);
	struct rec rec = { 0 };
	uint64_t index = 0, dps2;
	const char *sval;
	struct req q;
	uint8_t id = d->id;
	int r;

	if (argc == 1) {
		/* V3 §2.4: the position-planning acceleration; V2 §3.19: the one there is. */
		rmdctl_req_init(&q, id, 0x42);
		r = rmdctl_open_bus(d);
		if (r)
			return r;
		r = rmdctl_ask(d, &q);
		rmdctl_close_bus(d);
		if (r)
			return r;
		rmdctl_rec_add_req(&rec, d, &q, true);
		rmdctl_print_rec(d, id, &rec, (const enum rmd_field[]){ RMD_FLD_ACCEL }, 1);
		return RMDCTL_EXIT_OK;
	}
	if (v2 != (argc == 2)) {
		tool_log(TOOL_LOG_ERR, v2 ? "V2 writes one acceleration: accel ID DPS2" :
					    "V3 writes by index: accel ID INDEX DPS2");
		return RMDCTL_EXIT_USAGE;
	}
	if (!v2) {
		for (index = 0; index < 4 && strcmp(argv[1], accel_names[index]); index++)
			;
		if (index == 4 && rmdctl_parse_uint(argv[1], 0, 3, &index) < 0) {
			tool_log(TOOL_LOG_ERR,
				 "bad INDEX \"%s\" (0 position-accel, 1 position-decel, 2 "
				 "speed-accel, 3 speed-decel)",
				 argv[1]);
			return RMDCTL_EXIT_USAGE;
		}
	}
	sval = argv[argc - 1];
	if (rmdctl_parse_uint(sval, 0, INT32_MAX, &dps2) < 0 ||
	    (!d->force && (dps2 < ACCEL_MIN_DPS2 || dps2 > ACCEL_MAX_DPS2))) {
		tool_log(TOOL_LOG_ERR,
			 "bad DPS2 \"%s\" (%d..%d dps/s, V3 §2.5.1; --force for others)", sval,
			 ACCEL_MIN_DPS2, ACCEL_MAX_DPS2);
		return RMDCTL_EXIT_USAGE;
	}
	r = rmdctl_open_bus_for(d, !v2, "write an acceleration of motor %u on %s", id, d->bus_spec);
	if (r)
		return r;
	if (!v2) {
		r = rmdctl_confirm(d, "set %s of motor %u on %s to %" PRIu64 " dps/s (RAM and ROM)",
				   accel_names[index], id, d->name, dps2);
		if (r)
			goto out;
	}
	/* V3 §2.5: RAM and ROM, by index; V2 §3.20: RAM.  Both echo. */
	rmdctl_req_init(&q, id, 0x43);
	if (!v2)
		rmd_msg_set(&q.msg, RMD_FLD_INDEX, (int64_t)index);
	rmd_msg_set(&q.msg, RMD_FLD_ACCEL, (int64_t)dps2);
	r = rmdctl_ask(d, &q);
	if (r)
		goto out;
	if (d->json)
		printf("{\"bus\":\"%s\",\"motor_id\":%u,\"protocol\":\"%s\",\"index\":%" PRIu64
		       ",\"accel_dps2\":%" PRIu64 "}\n",
		       d->name, id, rmd_proto_name(d->proto), index, dps2);
	else
		printf("%s: motor %u: %s %" PRIu64 " dps/s written (%s), echo verified\n", d->name,
		       id, v2 ? "acceleration" : accel_names[index], dps2,
		       v2 ? "RAM" : "RAM and ROM");
out:
	rmdctl_close_bus(d);
	return r;
}

static const enum rmd_field pid_fields[6] = { RMD_FLD_CURR_KP, RMD_FLD_CURR_KI, RMD_FLD_SPD_KP,
					      RMD_FLD_SPD_KI,  RMD_FLD_POS_KP,	RMD_FLD_POS_KI };

static int pid_read(struct dev *d, uint8_t id)
{
	struct rec rec = { 0 };
	struct req q[6];
	unsigned n = 0;
	int r;

	if (rmdctl_dialect(d)->pid == RMD_PID_V2_PER_GAIN)
		for (unsigned i = 0; i < 6; i++)
			rmdctl_req_init(&q[n++], id, rmdctl_v2_pid_read[i]);
	else
		rmdctl_req_init(&q[n++], id, 0x30);
	r = rmdctl_exchange(d, q, n);
	if (r)
		return r;
	if (rmdctl_report_failed(d, q, n))
		return RMDCTL_EXIT_DATA;
	for (unsigned i = 0; i < n; i++)
		rmdctl_rec_add_req(&rec, d, &q[i], true);
	rmdctl_print_rec(d, id, &rec, pid_fields, 6);
	return RMDCTL_EXIT_OK;
}

int rmdctl_run_pid(struct dev *d, int argc, char **argv)
{
	/* V2 §3.1 .. §3.18: one Q24 gain a command; V3 §2.2: six uint8 gains in one */
	bool v2 = rmdctl_dialect(d)->pid == RMD_PID_V2_PER_GAIN;
	double g[6];
	struct req q[6];
	unsigned n = 0;
	uint8_t id = d->id;
	int r;

	/* V4.2 §2.1 .. §2.3: one float gain by index a frame; not read or written here yet */
	if (rmdctl_dialect(d)->pid == RMD_PID_FLOAT_INDEXED) {
		tool_log(TOOL_LOG_ERR,
			 "pid does not speak %s gains yet (one float by index): see "
			 "`rmdctl encode --protocol %s pid`",
			 rmdctl_dialect(d)->name, rmdctl_dialect(d)->key);
		return RMDCTL_EXIT_USAGE;
	}
	if (argc == 1) {
		if (d->rom) {
			tool_log(TOOL_LOG_ERR, "--rom applies to writing gains");
			return RMDCTL_EXIT_USAGE;
		}
		return pid_read(d, id);
	}
	if (argc != 7) {
		tool_log(TOOL_LOG_ERR,
			 "give all six gains: CURR_KP CURR_KI SPD_KP SPD_KI POS_KP POS_KI");
		return RMDCTL_EXIT_USAGE;
	}
	for (unsigned i = 0; i < 6; i++) {
		/* V3 §2.2: uint8 gains; V2 §3.7: Q24 reals. */
		if (rmdctl_parse_double(argv[1 + i], &g[i]) < 0 || g[i] < 0 ||
		    (!v2 && (g[i] > 255 || g[i] != floor(g[i]))) || (v2 && g[i] >= 128)) {
			tool_log(TOOL_LOG_ERR, "bad gain \"%s\" (%s)", argv[1 + i],
				 v2 ? "a real 0..127 (Q24)" : "an integer 0..255");
			return RMDCTL_EXIT_USAGE;
		}
	}
	if (v2) {
		for (unsigned i = 0; i < 6; i++) {
			/* V2 §3.7 .. §3.18: RAM 0x36.., ROM 0x3C.., six after each read. */
			uint8_t cmd = (uint8_t)(rmdctl_v2_pid_read[i] + (d->rom ? 12 : 6));

			rmdctl_req_init(&q[n], id, cmd);
			if (rmd_msg_set_native(&q[n].msg, rmdctl_spec(d, cmd), RMD_DIR_REQUEST,
					       pid_fields[i], g[i]) < 0) {
				tool_log(TOOL_LOG_ERR, "gain %g does not fit 0x%02X", g[i], cmd);
				return RMDCTL_EXIT_USAGE;
			}
			n++;
		}
	} else {
		/* V3 §2.2 (0x31, RAM) / §2.3 (0x32, ROM). */
		rmdctl_req_init(&q[n], id, d->rom ? 0x32 : 0x31);
		for (unsigned i = 0; i < 6; i++)
			rmd_msg_set(&q[n].msg, pid_fields[i], (int64_t)g[i]);
		n++;
	}
	r = rmdctl_open_bus_for(d, d->rom, "write the PID gains of motor %u on %s to ROM", id,
				d->bus_spec);
	if (r)
		return r;
	if (d->rom) {
		r = rmdctl_confirm(d, "write PID gains %g %g %g %g %g %g to motor %u on %s (ROM)",
				   g[0], g[1], g[2], g[3], g[4], g[5], id, d->name);
		if (r)
			goto out;
	}
	r = rmdctl_run_reqs(d, q, n);
	if (r)
		goto out;
	if (rmdctl_report_failed(d, q, n)) {
		r = RMDCTL_EXIT_DATA;
		goto out;
	}
	if (d->json) {
		struct rec rec = { 0 };

		for (unsigned i = 0; i < n; i++)
			rmdctl_rec_add(&rec, rmdctl_spec(d, q[i].msg.cmd), &q[i].msg, true);
		rmdctl_print_rec(d, id, &rec, pid_fields, 6);
	} else {
		printf("%s: motor %u: PID gains written to %s, echo verified\n", d->name, id,
		       d->rom ? "RAM and ROM" : "RAM (lost at power off; --rom keeps them)");
	}
out:
	rmdctl_close_bus(d);
	return r;
}
