// SPDX-License-Identifier: MIT
/*
 * Bring-up, before the rt thread starts: probe every configured motor
 * (model 0xB5, version 0xB2, status 0x9A), scan each bus for ids that
 * answer but are not configured, and write each motor's comm-loss
 * protection (0xB3).  Non-rt: blocks on the buses, formats text.
 */
#define _GNU_SOURCE
#include <errno.h>
#include <stdarg.h>
#include <stdio.h>
#include <string.h>

#include "rmd/bus_rs485.h"
#include "rmd/time.h"
#include "loop_priv.h"

struct report {
	char *buf;
	size_t len, used;
};

/* Non-rt. */
__attribute__((format(printf, 2, 3))) static void rep_add(struct report *r, const char *fmt, ...)
{
	va_list ap;
	int n;

	if (!r->buf || !r->len || r->used + 1 >= r->len)
		return;
	va_start(ap, fmt);
	n = vsnprintf(r->buf + r->used, r->len - r->used, fmt, ap);
	va_end(ap);
	if (n > 0)
		r->used += (size_t)n;
	if (r->used >= r->len)
		r->used = r->len - 1;
}

/* Bring-up: a frame nobody asked for; remember ids that are not configured.  Non-rt (bring-up). */
static void probe_stray(struct rmd_loop *l, unsigned b, const struct rmd_frame *f)
{
	uint32_t id = f->can_id;
	unsigned mid = 0;

	if (loop_motor_of(l, b, id))
		return;
	if (id > RMD_CAN_V3_REPLY_BASE && id <= RMD_CAN_V3_REPLY_BASE + RMD_MAX_MOTORS)
		mid = id - RMD_CAN_V3_REPLY_BASE;
	else if (id > RMD_CAN_REQ_BASE && id <= RMD_CAN_REQ_BASE + RMD_MAX_MOTORS)
		mid = id - RMD_CAN_REQ_BASE;
	else if (id > RMD_CAN_MIT_REPLY_BASE && id <= RMD_CAN_MIT_REPLY_BASE + RMD_MAX_MOTORS)
		mid = id - RMD_CAN_MIT_REPLY_BASE;
	if (mid)
		l->bus[b].unexpected_ids |= 1u << (mid - 1);
}

/* True when the reply to `cmd` repeats the request (RMD_CMD_ECHO).  Non-rt. */
static bool cmd_echoes(const struct lmotor *lm, uint8_t cmd)
{
	const struct rmd_cmd_spec *spec = rmd_cmd_find(lm->m.proto, cmd);

	return spec && (spec->flags & RMD_CMD_ECHO);
}

/*
 * One request to lm and its answer, with retries.  Returns 0 with the
 * answer in *rep, or -ETIMEDOUT.
 * Non-rt: blocks for a bounded time.
 */
static int probe_xfer(struct rmd_loop *l, struct lmotor *lm, const struct rmd_frame *req,
		      unsigned tries, int64_t timeout_ns, struct rmd_frame *rep)
{
	struct lbus *lb = &l->bus[lm->m.bus];
	bool check_echo, echo_seen = false;
	uint32_t rid;
	uint16_t cmd;

	rmd_motor_reply_key(&lm->m, req, &rid, &cmd);
	check_echo = cmd != RMD_MOTOR_CMD_MIT && !cmd_echoes(lm, (uint8_t)cmd);
	for (unsigned t = 0; t < tries; t++) {
		int64_t now = loop_now(l), deadline = now + timeout_ns;
		bool resend = false;

		rmd_bus_send(lb->bus, req, 1, now);
		while (!resend) {
			int n;

			now = loop_now(l);
			n = rmd_bus_recv(lb->bus, lb->rx, RX_BATCH, now);
			for (int k = 0; k < n; k++) {
				const struct rmd_frame *f = &lb->rx[k].f;

				if (f->can_id != rid || !f->len ||
				    (cmd != RMD_MOTOR_CMD_MIT && f->data[0] != cmd)) {
					probe_stray(l, lm->m.bus, f);
					continue;
				}
				/*
				 * A copy of a request whose answer is no copy: a motor
				 * whose comm-loss protection tripped echoes the first
				 * command and does not execute it.  Ask again; a second
				 * copy is the answer (V3 0x70 in mode 0 is all zeros).
				 */
				if (check_echo && !echo_seen && f->len == req->len &&
				    !memcmp(f->data, req->data, req->len)) {
					echo_seen = true;
					resend = true;
					break;
				}
				*rep = *f;
				return 0;
			}
			if (resend || now >= deadline)
				break;
			if (n < RX_BATCH)
				loop_wait_bus(l, lb->bus,
					      deadline - now < PROBE_STEP_NS ? deadline - now :
									       PROBE_STEP_NS);
		}
	}
	return -ETIMEDOUT;
}

/* Non-rt. */
static int probe_cmd(struct rmd_loop *l, struct lmotor *lm, uint8_t cmd, unsigned tries,
		     int64_t timeout_ns, struct rmd_motor_reply *r)
{
	struct rmd_frame req, rep;
	int ret = rmd_motor_encode_cmd(&lm->m, cmd, &req);

	if (ret < 0)
		return ret;
	ret = probe_xfer(l, lm, &req, tries, timeout_ns, &rep);
	if (ret < 0)
		return ret;
	return rmd_motor_decode(&lm->m, &rep, r) < 0 ? -EBADMSG : 0;
}

/* Probe motor i and write its report line.  Returns 0, or -ENODEV when it is missing.  Non-rt. */
static int probe_motor(struct rmd_loop *l, unsigned i, struct report *rp)
{
	const struct rmd_config_motor *c = &l->cfg->motors[i];
	struct lmotor *lm = &l->mot[i];
	struct lbus *lb = &l->bus[lm->m.bus];
	const char *bus = lb->cb->name;
	bool v2 = lm->m.proto == RMD_PROTO_V2;
	const unsigned tries = RMD_LOOP_PROBE_TRIES;
	int64_t timeout = RMD_LOOP_PROBE_TIMEOUT_NS;
	struct rmd_motor_reply r;
	uint8_t first = v2 ? 0x9A : 0xB5;
	int64_t now;
	int ret;

	if (lb->cb->kind == RMD_BUS_KIND_RS485)
		timeout = rmd_rs485_reply_timeout_ns(lb->bus) + RMD_NS_PER_MS;
	rep_add(rp, "%s: motor %u (%s): ", bus, c->id, c->name);
	/* V3 §2.32 model; V2 has no model or version query: its status answers */
	ret = probe_cmd(l, lm, first, tries, timeout, &r);
	now = loop_now(l);
	if (ret < 0) {
		rep_add(rp, "missing (no answer to 0x%02X in %u tries of %lld ms)\n", first, tries,
			(long long)(timeout / RMD_NS_PER_MS));
		loop_event(l, now, RMD_EV_PROBE, i, lm->m.bus, -ENODEV, 0);
		loop_enter(l, lm, RMD_LC_LOST, now);
		lm->next_probe_ns = now; /* the first cycle probes again */
		return -ENODEV;
	}
	if (!v2) {
		snprintf(lm->model, sizeof(lm->model), "%s", r.model);
		/* V3 §2.29 firmware date */
		if (probe_cmd(l, lm, 0xB2, tries, timeout, &r) == 0)
			lm->version = r.version_date;
		rep_add(rp, "%s", lm->model[0] ? lm->model : "(no model)");
		if (!lm->version)
			rep_add(rp, ", no answer to 0xB2");
		else if (rmd_version_date_valid(lm->version))
			rep_add(rp, ", firmware %u", (unsigned)lm->version);
		else
			rep_add(rp, ", firmware date %u implausible", (unsigned)lm->version);
		/* V3 §2.12 status 1 */
		ret = probe_cmd(l, lm, 0x9A, tries, timeout, &r);
	} else {
		rep_add(rp, "V2 (no model or version query)");
	}
	if (ret == 0) {
		rmd_motor_apply(&r, &lm->st);
		rep_add(rp, ", %.1f V, %.0f °C", r.voltage_v, r.temp_c);
		if (r.error_code) {
			const char *names[4];
			size_t n = rmd_error_names(v2 ? RMD_PROTO_V2 : RMD_PROTO_V3, r.error_code,
						   names, 4);

			rep_add(rp, ", errors 0x%04X (", r.error_code);
			for (size_t k = 0; k < n && k < 4; k++)
				rep_add(rp, "%s%s", k ? ", " : "", names[k]);
			rep_add(rp, "%s)", n > 4 ? ", ..." : "");
		}
	} else {
		rep_add(rp, ", no answer to 0x9A");
	}
	if (v2) {
		/* V2 §3.29: the multi-turn angle anchors the unwrapped encoder */
		if (probe_cmd(l, lm, 0x92, tries, timeout, &r) == 0 &&
		    (r.have & RMD_MOTOR_HAVE_POS))
			rmd_motor_set_v2_reference(&lm->m,
						   rmd_motor_to_native_pos(&lm->m, r.pos_rad));
		else
			rep_add(rp, ", no 0x92 angle: positions start at 0");
		rep_add(rp, ", no 0xB3 in V2 (no comm-loss protection)");
	}
	rep_add(rp, "\n");
	now = loop_now(l);
	loop_event(l, now, RMD_EV_PROBE, i, lm->m.bus, 0, lm->version);
	lm->consecutive = 0;
	loop_enter(l, lm, RMD_LC_READY, now);
	if (lm->st.error_code)
		loop_note_errors(l, lm, 0, now);
	return 0;
}

/*
 * Ask every id that is not configured on bus b for its status (0x9A, read
 * only; V3 §2.12 on 0x140 + ID, which V2 motors take as well), all at
 * once, and note who answers.  Bounded: one try, the wire time of the
 * requests (RS485: one reply timeout each) plus RMD_LOOP_PROBE_TIMEOUT_NS.
 * Non-rt.
 */
static void scan_bus(struct rmd_loop *l, unsigned b)
{
	struct lbus *lb = &l->bus[b];
	struct rmd_frame req[RMD_MAX_MOTORS];
	unsigned n = 0, off = 0;
	int64_t now = loop_now(l), end;

	for (unsigned id = 1; id <= RMD_MAX_MOTORS; id++) {
		struct rmd_msg msg;

		if (lb->by_v3[id] || lb->by_v2[id] || lb->by_mit[id])
			continue;
		memset(&msg, 0, sizeof(msg));
		msg.cmd = 0x9A;
		if (rmd_encode(RMD_PROTO_V3, RMD_DIR_REQUEST, (uint8_t)id, &msg, &req[n]) == 0)
			n++;
	}
	if (lb->cb->kind == RMD_BUS_KIND_RS485)
		end = now + (int64_t)(n + 1) * rmd_rs485_reply_timeout_ns(lb->bus);
	else
		end = now + rmd_plan_cost_ns(lb->pb, 2 * n, n);
	end += RMD_LOOP_PROBE_TIMEOUT_NS;
	while (now < end) {
		int r;

		if (off < n) {
			r = rmd_bus_send(lb->bus, req + off, n - off, now);
			if (r > 0)
				off += (unsigned)r;
		}
		r = rmd_bus_recv(lb->bus, lb->rx, RX_BATCH, now);
		for (int k = 0; k < r; k++)
			probe_stray(l, b, &lb->rx[k].f);
		if (r < RX_BATCH)
			loop_wait_bus(l, lb->bus,
				      end - now < PROBE_STEP_NS ? end - now : PROBE_STEP_NS);
		now = loop_now(l);
	}
}

/* Non-rt. */
/*
 * V3 §2.30: write the comm-loss protection time (ROM) to every motor of bus
 * b that answered the probe, and check each echo, as the last step of
 * bring-up: a motor starts counting at the write, and the loop's first
 * cycle follows at once.  One report line per bus.  Non-rt.
 */
static void arm_comm_loss(struct rmd_loop *l, unsigned b, struct report *rp)
{
	struct lbus *lb = &l->bus[b];
	uint32_t ms = l->cfg->safety.comm_loss_ms;
	int64_t timeout = RMD_LOOP_PROBE_TIMEOUT_NS;
	unsigned set = 0;
	bool any = false;

	if (lb->cb->kind == RMD_BUS_KIND_RS485)
		timeout = rmd_rs485_reply_timeout_ns(lb->bus) + RMD_NS_PER_MS;
	for (unsigned i = 0; i < l->n_motors; i++) {
		struct lmotor *lm = &l->mot[i];
		const struct rmd_config_motor *c = &l->cfg->motors[i];
		struct rmd_frame req, echo;

		if (lm->m.bus != b || lm->m.proto == RMD_PROTO_V2 ||
		    lm->st.lifecycle == RMD_LC_LOST)
			continue;
		if (!any)
			rep_add(rp, "%s: comm-loss protection (0xB3) %s", lb->cb->name,
				ms ? "" : "off (disabled by safety.comm_loss_ms: 0)");
		if (ms && !any)
			rep_add(rp, "%u ms:", (unsigned)ms);
		any = true;
		if (rmd_motor_encode_comm_timeout(&lm->m, ms, &req) < 0 ||
		    probe_xfer(l, lm, &req, RMD_LOOP_PROBE_TRIES, timeout, &echo) < 0) {
			rep_add(rp, " motor %u (%s) did not answer 0xB3;", c->id, c->name);
		} else if (echo.len != req.len || memcmp(echo.data, req.data, RMD_FRAME_LEN)) {
			rep_add(rp, " motor %u (%s) NOT confirmed (the echo differs);", c->id,
				c->name);
		} else {
			rep_add(rp, " %u", c->id);
			set++;
		}
	}
	if (any)
		rep_add(rp, " (%u set, echo verified)\n", set);
}

int rmd_loop_bringup(struct rmd_loop *l, char *report, size_t len)
{
	struct report rp = { .buf = report, .len = len };
	unsigned missing = 0;

	if (report && len)
		report[0] = '\0';
	if (l->running)
		return -EBUSY;
	for (unsigned b = 0; b < l->n_buses; b++) {
		struct lbus *lb = &l->bus[b];
		int64_t now = loop_now(l);

		lb->unexpected_ids = 0;
		/* what came before the first request answers none of them */
		while (rmd_bus_recv(lb->bus, lb->rx, RX_BATCH, now) == RX_BATCH)
			;
	}
	for (unsigned i = 0; i < l->n_motors; i++)
		if (probe_motor(l, i, &rp) < 0)
			missing++;
	for (unsigned b = 0; b < l->n_buses; b++) {
		struct lbus *lb = &l->bus[b];
		int64_t now = loop_now(l);
		int n;

		/* late answers tell of ids too */
		while ((n = rmd_bus_recv(lb->bus, lb->rx, RX_BATCH, now)) > 0) {
			for (int k = 0; k < n; k++)
				probe_stray(l, b, &lb->rx[k].f);
			if (n < RX_BATCH)
				break;
		}
		scan_bus(l, b);
		now = loop_now(l);
		for (unsigned id = 1; id <= RMD_MAX_MOTORS; id++) {
			if (!(lb->unexpected_ids & (1u << (id - 1))))
				continue;
			rep_add(&rp, "%s: motor %u: unexpected (answers, but is not configured)\n",
				lb->cb->name, id);
			loop_event(l, now, RMD_EV_PROBE, 0xFF, b, -EEXIST, id);
		}
	}
	/* last, so that no motor goes quiet between its 0xB3 and the first cycle */
	for (unsigned b = 0; b < l->n_buses; b++)
		arm_comm_loss(l, b, &rp);
	if (rp.used && report[rp.used - 1] == '\n')
		report[--rp.used] = '\0';
	/* what bring-up found is the state before the first cycle */
	loop_fill_snapshot(l, loop_now(l));
	loop_pub_write(l);
	if (missing && l->cfg->probe.on_missing == RMD_MISSING_REFUSE)
		return -ENODEV;
	return 0;
}
