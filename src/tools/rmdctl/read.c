// SPDX-License-Identifier: MIT
/*
 * rmdctl scan, info, status, monitor: commands that only read.  Non-rt.
 */
#include <inttypes.h>
#include <math.h>
#include <stdint.h>
#include <stdio.h>
#include <string.h>
#include <unistd.h>

#include "rmd/time.h"
#include "rmd/codec.h"
#include "rmd/describe.h"
#include "rmdctl.h"

/* ---- scan ----------------------------------------------------------------------------- */

int rmdctl_run_scan(struct dev *d, int argc, char **argv)
{
	static const enum rmd_field cols[] = { RMD_FLD_MODEL,	RMD_FLD_VERSION, RMD_FLD_TEMP,
					       RMD_FLD_VOLTAGE, RMD_FLD_BRAKE,	 RMD_FLD_ERROR };
	uint8_t ids[RMD_MAX_MOTORS], found[RMD_MAX_MOTORS];
	struct req st[RMD_MAX_MOTORS], info[2 * RMD_MAX_MOTORS];
	/* V3 §2.32, §2.29: model and firmware date */
	bool ident =
		rmd_dialect_has(rmdctl_dialect(d), RMD_DIALECT_MODEL_B5 | RMD_DIALECT_VERSION_B2);
	int64_t t0 = rmd_now_ns();
	unsigned n, ni = 0;
	int m, r;
	char ms[32], pk[8];

	m = rmdctl_ids_open(d, argc, argv, ids);
	if (m < 0)
		return -m;
	n = (unsigned)m;
	/* 0x9A first: every protocol has it.  Then model and version of those that answered. */
	m = rmdctl_probe(d, ids, n, found, st);
	if (m < 0) {
		rmdctl_close_bus(d);
		return -m;
	}
	if (ident) {
		for (int i = 0; i < m; i++) {
			rmdctl_req_init(&info[ni++], found[i], 0xB5);
			rmdctl_req_init(&info[ni++], found[i], 0xB2);
		}
		r = rmdctl_run_reqs(d, info, ni);
		if (r) {
			rmdctl_close_bus(d);
			return r;
		}
		rmdctl_report_failed(d, info, ni);
	}
	if (!d->json && m > 0)
		printf("%3s  %-8s %-10s %-5s %6s %9s  %-8s %s\n", "ID", "MODEL", "FIRMWARE",
		       "PROTO", "TEMP_C", "VOLTAGE_V", "BRAKE", "ERRORS");
	for (unsigned i = 0, k = 0; i < n; i++) {
		struct rec rec = { 0 };
		char c[6][64];

		if (!st[i].ok)
			continue;
		rmdctl_rec_add_req(&rec, d, &st[i], true);
		for (; k < ni && info[k].id <= ids[i]; k++)
			if (info[k].id == ids[i])
				rmdctl_rec_add_req(&rec, d, &info[k], true);
		if (d->json) {
			rmdctl_print_rec(d, ids[i], &rec, cols, sizeof(cols) / sizeof(cols[0]));
			continue;
		}
		for (unsigned j = 0; j < 6; j++)
			rmdctl_field_text(d, &rec, cols[j], c[j], sizeof(c[j]));
		/* the dialect its firmware date says, "?" when the date tells none */
		{
			bool certain;
			const struct rmd_dialect *fw = rmdctl_rec_dialect(d, &rec, &certain);

			snprintf(pk, sizeof(pk), "%s%s", fw ? fw->key : rmd_proto_key(d->proto),
				 fw && !certain ? "?" : "");
		}
		printf("%3u  %-8s %-10s %-5s %6s %9s  %-8s %s\n", ids[i], c[0], c[1], pk, c[2],
		       c[3], c[4], c[5]);
	}
	if (m == 0 && d->wait_auto)
		tool_log(TOOL_LOG_ERR,
			 "%s: no motor answered 0x9A (%u ids probed, %s, %u %s, the first %d ms, "
			 "then %s ms each)",
			 d->name, n, rmd_proto_name(d->proto), d->tries,
			 d->tries == 1 ? "try" : "tries", RMDCTL_WAIT_PROBE_MS,
			 rmdctl_ms_str(ms, sizeof(ms), d->timeout_ms));
	else if (m == 0)
		tool_log(TOOL_LOG_ERR,
			 "%s: no motor answered 0x9A (%u ids probed, %s, %s ms x %u tries)",
			 d->name, n, rmd_proto_name(d->proto),
			 rmdctl_ms_str(ms, sizeof(ms), d->timeout_ms), d->tries);
	else if (!d->json)
		printf("%s: %d motor%s answered (%u ids probed in %.0f ms)\n", d->name, m,
		       m == 1 ? "" : "s", n, (double)(rmd_now_ns() - t0) / 1e6);
	rmdctl_close_bus(d);
	return m > 0 ? RMDCTL_EXIT_OK : RMDCTL_EXIT_DATA;
}

/* ---- info, status --------------------------------------------------------------------- */

int rmdctl_run_info(struct dev *d, int argc, char **argv)
{
	static const enum rmd_field order[] = {
		RMD_FLD_MODEL,	 RMD_FLD_VERSION, RMD_FLD_RUNTIME, RMD_FLD_ACCEL,
		RMD_FLD_CURR_KP, RMD_FLD_CURR_KI, RMD_FLD_SPD_KP,  RMD_FLD_SPD_KI,
		RMD_FLD_POS_KP,	 RMD_FLD_POS_KI,  RMD_FLD_POS_KD,  RMD_FLD_MODE,
	};
	const struct rmd_dialect *dl = rmdctl_dialect(d);
	struct req q[5 + RMD_PID_SLOTS_MAX];
	struct rmd_pid_set gains;
	struct rec rec = { 0 };
	unsigned n = 0, bad;
	uint8_t id = d->id;
	bool has_kd = false;
	int r;

	(void)argc;
	(void)argv;
	if (rmd_dialect_has(dl, RMD_DIALECT_MODEL_B5 | RMD_DIALECT_VERSION_B2)) {
		rmdctl_req_init(&q[n++], id, 0xB5); /* V3 §2.32 */
		rmdctl_req_init(&q[n++], id, 0xB2); /* V3 §2.29 */
		rmdctl_req_init(&q[n++], id, 0xB1); /* V3 §2.28 */
	}
	/* V3 §2.1: one 0x30, six gains; V2 §3.1: a read a gain; V4.2 §2.1: 0x30 by index */
	n += rmdctl_pid_read_reqs(d, id, q + n);
	/* V3 §2.4 / V2 §3.19; V4.2 §2.4: index 0, the position-planning acceleration */
	rmdctl_req_init(&q[n], id, 0x42);
	rmd_msg_set(&q[n++].msg, RMD_FLD_INDEX, 0);
	rmdctl_req_init(&q[n++], id, 0x70); /* V3 §2.23 / V2 §3.45 */
	r = rmdctl_open_bus(d);
	if (r)
		return r;
	r = rmdctl_run_reqs(d, q, n);
	rmdctl_close_bus(d);
	if (r)
		return r;
	bad = rmdctl_report_failed(d, q, n);
	if (bad == n)
		return RMDCTL_EXIT_DATA;
	bad += rmdctl_pid_gather(d, q, n, &gains);
	for (unsigned i = 0; i < n; i++)
		rmdctl_rec_add_req(&rec, d, &q[i], true);
	rmdctl_rec_add_gains(&rec, d, &gains);
	/* position KD only where the layout has it (V4.2 §2.1.4 index 9) */
	size_t n_order = sizeof(order) / sizeof(order[0]);
	enum rmd_field shown[sizeof(order) / sizeof(order[0])];
	size_t k = 0;

	for (unsigned i = 0; i < dl->n_pid_slots; i++)
		has_kd |= dl->pid_slots[i].field == RMD_FLD_POS_KD;
	for (size_t i = 0; i < n_order; i++)
		if (order[i] != RMD_FLD_POS_KD || has_kd)
			shown[k++] = order[i];
	if (d->json) {
		rmdctl_json_begin(d, id);
		for (size_t i = 0; i < k; i++)
			rmdctl_json_field(d, &rec, shown[i]);
		/* V3 §2.30: 0xB3 only writes; nothing reads the timeout back. */
		fputs(",\"timeout_ms\":null}\n", stdout);
	} else {
		rmdctl_print_rec(d, id, &rec, shown, k);
		printf("  %-16s %s\n", "comm timeout",
		       "not readable (0xB3 only writes it; see `rmdctl set-timeout`)");
	}
	return bad ? RMDCTL_EXIT_DATA : RMDCTL_EXIT_OK;
}

static const enum rmd_field status_fields[] = {
	RMD_FLD_TEMP,  RMD_FLD_VOLTAGE, RMD_FLD_ERROR,	 RMD_FLD_BRAKE,
	RMD_FLD_ANGLE, RMD_FLD_SPEED,	RMD_FLD_CURRENT,
};

/* Status reads of one motor. */
static void status_reqs(struct req *q, uint8_t id)
{
	rmdctl_req_init(&q[0], id, 0x9A); /* V3 §2.12 / V2 §3.31 */
	rmdctl_req_init(&q[1], id, 0x92); /* V3 §2.11 / V2 §3.29 */
	rmdctl_req_init(&q[2], id, 0x9C); /* V3 §2.13 / V2 §3.32 */
}

/* 0x92's angle (0.01 deg) goes in first, so 0x9C's whole degrees do not replace it. */
static void status_rec(const struct dev *d, const struct req *q, struct rec *rec)
{
	memset(rec, 0, sizeof(*rec));
	rmdctl_rec_add_req(rec, d, &q[1], false);
	rmdctl_rec_add_req(rec, d, &q[0], false);
	rmdctl_rec_add_req(rec, d, &q[2], false);
}

int rmdctl_run_status(struct dev *d, int argc, char **argv)
{
	struct req q[3];
	struct rec rec;
	unsigned bad;
	uint8_t id = d->id;
	int r;

	(void)argc;
	(void)argv;
	status_reqs(q, id);
	r = rmdctl_exchange(d, q, 3);
	if (r)
		return r;
	bad = rmdctl_report_failed(d, q, 3);
	if (bad == 3)
		return RMDCTL_EXIT_DATA;
	status_rec(d, q, &rec);
	rmdctl_print_rec(d, id, &rec, status_fields,
			 sizeof(status_fields) / sizeof(status_fields[0]));
	return bad ? RMDCTL_EXIT_DATA : RMDCTL_EXIT_OK;
}

/* ---- monitor -------------------------------------------------------------------------- */

static void monitor_table(struct dev *d, const uint8_t *ids, unsigned n, const struct req *q,
			  bool clear)
{
	static const enum rmd_field cols[] = { RMD_FLD_TEMP,  RMD_FLD_VOLTAGE, RMD_FLD_ANGLE,
					       RMD_FLD_SPEED, RMD_FLD_CURRENT, RMD_FLD_BRAKE,
					       RMD_FLD_ERROR };
	double t_s = (double)(rmd_now_ns() - d->t0_ns) / 1e9;
	char ms[32];

	if (d->json) {
		for (unsigned i = 0; i < n; i++) {
			struct rec rec;

			status_rec(d, &q[3 * i], &rec);
			rmdctl_json_begin(d, ids[i]);
			printf(",\"time_s\":%.3f,\"answered\":%s", t_s,
			       q[3 * i].ok || q[3 * i + 1].ok || q[3 * i + 2].ok ? "true" :
										   "false");
			for (size_t j = 0; j < sizeof(cols) / sizeof(cols[0]); j++)
				rmdctl_json_field(d, &rec, cols[j]);
			fputs("}\n", stdout);
		}
		fflush(stdout);
		return;
	}
	if (clear)
		fputs("\033[H\033[2J", stdout);
	printf("%s (%s)  %u motor%s  every %s ms  t=%.1f s%s\n", d->name, rmd_proto_name(d->proto),
	       n, n == 1 ? "" : "s", rmdctl_ms_str(ms, sizeof(ms), d->interval_ms), t_s,
	       d->once ? "" : "  (Ctrl-C quits)");
	printf("%3s %7s %10s %11s %10s %10s  %-8s %s\n", "ID", "TEMP_C", "VOLTAGE_V", "ANGLE_DEG",
	       "SPEED_DPS", "CURRENT_A", "BRAKE", "ERRORS");
	for (unsigned i = 0; i < n; i++) {
		const struct req *mq = &q[3 * i];
		struct rec rec;
		char c[7][64];

		if (!mq[0].ok && !mq[1].ok && !mq[2].ok) {
			printf("%3u %s\n", ids[i], "no answer");
			continue;
		}
		status_rec(d, mq, &rec);
		for (unsigned j = 0; j < 7; j++)
			rmdctl_field_text(d, &rec, cols[j], c[j], sizeof(c[j]));
		printf("%3u %7s %10s %11s %10s %10s  %-8s %s\n", ids[i], c[0], c[1], c[2], c[3],
		       c[4], c[5], c[6]);
	}
	fflush(stdout);
}

int rmdctl_run_monitor(struct dev *d, int argc, char **argv)
{
	uint8_t ids[RMD_MAX_MOTORS];
	struct req q[MAX_REQS];
	bool clear = !d->once && isatty(STDOUT_FILENO);
	int64_t period = (int64_t)llround(d->interval_ms * 1e6), next;
	unsigned n;
	int m, r, status = RMDCTL_EXIT_OK;

	if (argc == 0) {
		/* No list: the motors that answer a probe. */
		char none[24];

		snprintf(none, sizeof(none), " (ids 1..%d)", RMD_MAX_MOTORS);
		m = rmdctl_ids_probe(d, argc, argv, ids, q, none);
	} else {
		m = rmdctl_ids_open(d, argc, argv, ids);
	}
	if (m < 0)
		return -m;
	n = (unsigned)m;
	next = rmd_now_ns();
	while (!rmdctl_interrupted) {
		for (unsigned i = 0; i < n; i++)
			status_reqs(&q[3 * i], ids[i]);
		r = rmdctl_run_reqs(d, q, 3 * n);
		if (r) {
			status = rmdctl_interrupted ? RMDCTL_EXIT_OK : r;
			break;
		}
		monitor_table(d, ids, n, q, clear);
		if (d->once) {
			if (rmdctl_report_failed(d, q, 3 * n))
				status = RMDCTL_EXIT_DATA;
			break;
		}
		next += period;
		if (next < rmd_now_ns())
			next = rmd_now_ns(); /* late: skip, never catch up in a burst */
		rmdctl_sleep_until(next);
	}
	rmdctl_close_bus(d);
	return status;
}
