// SPDX-License-Identifier: MIT
/*
 * Arming a motor's comm-loss protection (rmd/proc_arm.h).
 *
 * Execution context: pure, rt-safe.
 */
#include <string.h>

#include "rmd/proc_arm.h"

void rmd_arm_forget(struct rmd_arm *a, uint32_t comm_loss_ms, bool has_b3)
{
	if (!comm_loss_ms)
		a->cl = RMD_CL_OFF;
	else if (!has_b3)
		a->cl = RMD_CL_UNSUPPORTED;
	else
		a->cl = RMD_CL_PENDING;
	a->round = false;
	a->want = false;
	a->warned = false;
}

void rmd_arm_start_round(struct rmd_arm *a)
{
	a->round = true;
	a->differs = false;
	a->tries = 0;
	a->try_end_ns = INT64_MIN; /* the first write goes out at once */
}

enum rmd_arm_want rmd_arm_enable_wanted(struct rmd_arm *a, const struct rmd_setpoint *sp,
					int64_t now_ns)
{
	if (a->cl == RMD_CL_UNSUPPORTED)
		return RMD_ARM_REFUSE; /* nothing to write */
	if (!a->round && now_ns - a->round_end_ns < RMD_ARM_ROUND_NS)
		return RMD_ARM_REFUSE;
	if (!a->round)
		rmd_arm_start_round(a);
	a->want = true;
	a->sp = *sp;
	return RMD_ARM_WAIT;
}

bool rmd_arm_refused(struct rmd_arm *a)
{
	a->rejects++;
	if (a->warned)
		return false;
	a->warned = true;
	return true;
}

enum rmd_arm_step rmd_arm_step(struct rmd_arm *a, bool reachable, int64_t now_ns)
{
	if (!a->round || !reachable || now_ns < a->try_end_ns)
		return RMD_ARM_IDLE;
	if (a->tries < RMD_ARM_TRIES)
		return RMD_ARM_WRITE;
	a->round = false;
	a->cl = a->differs ? RMD_CL_DIFFERS : RMD_CL_NO_ANSWER;
	a->round_end_ns = now_ns;
	return RMD_ARM_FAILED;
}

void rmd_arm_written(struct rmd_arm *a, int64_t answer_due_ns)
{
	a->tries++;
	a->try_end_ns = answer_due_ns;
}

enum rmd_comm_loss rmd_arm_b3_outcome(const uint8_t *req, const struct rmd_frame *rep)
{
	static const uint8_t zeros[RMD_FRAME_LEN - 1];

	if (rep->len == RMD_FRAME_LEN && !memcmp(rep->data, req, RMD_FRAME_LEN))
		return RMD_CL_ARMED;
	if (rep->len == RMD_FRAME_LEN && rep->data[0] == req[0] &&
	    !memcmp(rep->data + 1, zeros, sizeof(zeros)))
		return RMD_CL_ARMED_ZEROS;
	return RMD_CL_DIFFERS;
}

enum rmd_arm_answer rmd_arm_answer(struct rmd_arm *a, const uint8_t *req,
				   const struct rmd_frame *rep, int64_t now_ns)
{
	enum rmd_comm_loss cl = rmd_arm_b3_outcome(req, rep);
	bool was = rmd_comm_loss_set(a->cl);

	if (a->cl == RMD_CL_OFF || a->cl == RMD_CL_UNSUPPORTED)
		return RMD_ARM_NOTHING;
	if (!rmd_comm_loss_set(cl)) {
		a->differs = true;
		if (!a->round)
			a->cl = RMD_CL_DIFFERS;
		return RMD_ARM_OTHER_TIME;
	}
	a->cl = (uint8_t)cl;
	a->round = false;
	a->warned = false;
	a->round_end_ns = now_ns;
	return was ? RMD_ARM_STILL_ARMED : RMD_ARM_NOW_ARMED;
}

void rmd_arm_took_over(struct rmd_arm *a, uint32_t comm_loss_ms, bool has_b3, enum rmd_comm_loss cl,
		       int64_t now_ns)
{
	rmd_arm_forget(a, comm_loss_ms, has_b3);
	if (a->cl == RMD_CL_PENDING)
		a->cl = (uint8_t)cl;
	a->round_end_ns = now_ns;
}

void rmd_arm_request(uint32_t comm_loss_ms, struct rmd_msg *msg)
{
	memset(msg, 0, sizeof(*msg));
	msg->cmd = RMD_ARM_CMD;
	rmd_msg_set(msg, RMD_FLD_TIMEOUT, comm_loss_ms);
}
