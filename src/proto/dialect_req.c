// SPDX-License-Identifier: MIT
/*
 * The requests of a motor's settings (rmd/dialect.h): its PID gains, read
 * and written by the commands of its dialect's slots, and its CAN ID.
 * Built from the record, so rmdctl, which sends them, and the simulated
 * motor, which answers them, hold no layout of their own.  Pure, rt-safe.
 */
#include <errno.h>
#include <stdbool.h>
#include <stdint.h>
#include <string.h>

#include "rmd/dialect.h"

#define BIT(k) (UINT32_C(1) << (k))

enum rmd_field rmd_pid_field(const struct rmd_dialect *d, unsigned k)
{
	const struct rmd_pid_slot *s = &d->pid_slots[k];

	return s->index ? RMD_FLD_GAIN : (enum rmd_field)s->field;
}

const struct rmd_field_spec *rmd_pid_spec(const struct rmd_dialect *d, unsigned k)
{
	const struct rmd_cmd_spec *row;

	if (k >= d->n_pid_slots)
		return NULL;
	row = rmd_cmd_find(d->table, d->pid_slots[k].cmd[RMD_PID_READ]);
	return row ? rmd_layout_field(row, RMD_DIR_REPLY, rmd_pid_field(d, k)) : NULL;
}

/* The request of reqs[0..n) that slot s of a shared frame travels in (no index, same command). */
static struct rmd_msg *shared_frame(struct rmd_msg *reqs, unsigned n, uint8_t cmd)
{
	for (unsigned j = 0; j < n; j++)
		if (reqs[j].cmd == cmd && !rmd_msg_has(&reqs[j], RMD_FLD_INDEX))
			return &reqs[j];
	return NULL;
}

int rmd_pid_requests(const struct rmd_dialect *d, enum rmd_pid_op op, const struct rmd_pid_set *set,
		     struct rmd_msg *reqs)
{
	unsigned n = 0;

	if ((unsigned)op >= RMD_PID_OPS)
		return -EINVAL;
	if (!d->n_pid_slots)
		return -ENOTSUP;
	for (unsigned k = 0; k < d->n_pid_slots && k < RMD_PID_SLOTS_MAX; k++) {
		const struct rmd_pid_slot *s = &d->pid_slots[k];
		struct rmd_msg *m = s->index ? NULL : shared_frame(reqs, n, s->cmd[op]);

		if (!(set->slots & BIT(k)))
			continue;
		if (!m) {
			m = &reqs[n++];
			memset(m, 0, sizeof(*m));
			m->cmd = s->cmd[op];
		}
		if (s->index) /* V4.2 §2.1.4 */
			rmd_msg_set(m, RMD_FLD_INDEX, s->index);
		if (op != RMD_PID_READ)
			rmd_msg_set(m, rmd_pid_field(d, k), set->raw[k]);
	}
	/* V3 §2.2: a frame of six gains writes all six */
	for (unsigned k = 0; op != RMD_PID_READ && k < d->n_pid_slots && k < RMD_PID_SLOTS_MAX;
	     k++) {
		const struct rmd_pid_slot *s = &d->pid_slots[k];
		struct rmd_msg *m = s->index ? NULL : shared_frame(reqs, n, s->cmd[op]);

		if (m && !(set->slots & BIT(k)))
			rmd_msg_set(m, (enum rmd_field)s->field, set->raw[k]);
	}
	return (int)n;
}

bool rmd_pid_parse(const struct rmd_dialect *d, const struct rmd_msg *msg, enum rmd_pid_op *op,
		   uint32_t *named, struct rmd_pid_set *carried)
{
	bool mine = false;

	*named = 0;
	carried->slots = 0;
	for (unsigned k = 0; k < d->n_pid_slots && k < RMD_PID_SLOTS_MAX; k++) {
		const struct rmd_pid_slot *s = &d->pid_slots[k];
		enum rmd_field f = rmd_pid_field(d, k);

		for (unsigned o = 0; o < RMD_PID_OPS; o++) {
			if (s->cmd[o] != msg->cmd)
				continue;
			mine = true;
			*op = (enum rmd_pid_op)o;
			if (s->index &&
			    (!rmd_msg_has(msg, RMD_FLD_INDEX) || msg->v[RMD_FLD_INDEX] != s->index))
				break;
			*named |= BIT(k);
			if (rmd_msg_has(msg, f)) {
				carried->slots |= BIT(k);
				carried->raw[k] = msg->v[f];
			}
			break;
		}
	}
	return mine;
}

void rmd_pid_answer(const struct rmd_dialect *d, const struct rmd_msg *req,
		    const struct rmd_pid_set *set, struct rmd_msg *rep)
{
	struct rmd_pid_set asked;
	enum rmd_pid_op op;
	uint32_t named;

	memset(rep, 0, sizeof(*rep));
	rep->cmd = req->cmd;
	if (!rmd_pid_parse(d, req, &op, &named, &asked))
		return;
	for (unsigned k = 0; k < d->n_pid_slots && k < RMD_PID_SLOTS_MAX; k++) {
		if (!(named & BIT(k)))
			continue;
		/* V4.2 §2.1.3: the answer names its index */
		if (d->pid_slots[k].index)
			rmd_msg_set(rep, RMD_FLD_INDEX, d->pid_slots[k].index);
		rmd_msg_set(rep, rmd_pid_field(d, k), set->slots & BIT(k) ? set->raw[k] : 0);
	}
}

int rmd_set_id_request(const struct rmd_dialect *d, uint8_t new_id, struct rmd_set_id_req *out)
{
	memset(out, 0, sizeof(*out));
	if (new_id < 1 || new_id > RMD_MAX_MOTORS)
		return -EINVAL;
	switch (d->set_id) {
	case RMD_SET_ID_79_OWN:
	case RMD_SET_ID_79_300:
		/* V2 §3.52, V3 §4.2: read flag 0 writes */
		out->write.cmd = 0x79;
		rmd_msg_set(&out->write, RMD_FLD_READ_FLAG, 0);
		rmd_msg_set(&out->write, RMD_FLD_CAN_ID, new_id);
		out->every_motor = rmd_dialect_set_id_can(d) != 0;
		return 0;
	case RMD_SET_ID_FUNC_20:
		/*
		 * V4.2 §2.34.4: 0x20 index 5 writes the ID to ROM, 0x76 (§2.25)
		 * makes it effective; firmware 2025070202 echoes from the new ID
		 */
		out->write.cmd = 0x20;
		rmd_msg_set(&out->write, RMD_FLD_INDEX, 5);
		rmd_msg_set(&out->write, RMD_FLD_VALUE, new_id);
		out->echo_from_new = true;
		out->then_reset = true;
		out->reset.cmd = 0x76;
		return 0;
	case RMD_SET_ID_NONE:
		break;
	}
	return -ENOTSUP;
}

bool rmd_set_id_parse(const struct rmd_dialect *d, const struct rmd_msg *req, int64_t *id)
{
	switch (d->set_id) {
	case RMD_SET_ID_79_OWN:
	case RMD_SET_ID_79_300:
		if (req->cmd != 0x79 || req->v[RMD_FLD_READ_FLAG] != 0)
			return false;
		*id = req->v[RMD_FLD_CAN_ID];
		return true;
	case RMD_SET_ID_FUNC_20:
		if (req->cmd != 0x20 || req->v[RMD_FLD_INDEX] != 5)
			return false;
		*id = req->v[RMD_FLD_VALUE];
		return true;
	case RMD_SET_ID_NONE:
		break;
	}
	return false;
}

int64_t rmd_set_id_read_answer(const struct rmd_dialect *d, uint8_t id)
{
	switch (d->set_id) {
	case RMD_SET_ID_79_OWN:
		return id; /* V2 §3.52 */
	case RMD_SET_ID_79_300:
		return (int64_t)d->reply_base + id; /* V3 §4.4 example 2: 0x0242 */
	case RMD_SET_ID_FUNC_20:
	case RMD_SET_ID_NONE:
		break;
	}
	return -1;
}
