// SPDX-License-Identifier: MIT
/*
 * The adapter between a simulated bus and the host (rmd/sim_adapter.h).
 */
#include <stdint.h>

#include "rmd/codec.h"
#include "rmd/sim_adapter.h"

void rmd_sim_adapter_init(struct rmd_sim_adapter *a)
{
	a->holding = false;
	a->flush_ns = 0;
}

bool rmd_sim_adapter_active(const struct rmd_sim_motor_params *p)
{
	return p->adapter_latency_timer_ns > 0 || p->adapter_usb_frame_ns > 0 ||
	       p->adapter_delay_ns > 0;
}

int64_t rmd_sim_adapter_ns(struct rmd_sim_adapter *a, const struct rmd_sim_motor_params *p,
			   int64_t t_ns)
{
	int64_t t = t_ns;
	int64_t timer = (int64_t)p->adapter_latency_timer_ns;
	int64_t usb = (int64_t)p->adapter_usb_frame_ns;

	if (timer > 0) {
		/* the timer runs from the first byte held; later bytes join the batch */
		if (!a->holding || t > a->flush_ns) {
			a->holding = true;
			a->flush_ns = t + timer;
		}
		t = a->flush_ns;
	}
	/* the end of the USB frame the frame fell in (time 0 starts one) */
	if (usb > 0 && t % usb)
		t += usb - t % usb;
	return t + (int64_t)p->adapter_delay_ns;
}

int64_t rmd_sim_adapter_answer_ns(struct rmd_sim_motor *m, const struct rmd_frame *req)
{
	int64_t t = rmd_sim_motor_turnaround_ns(m);
	const struct rmd_cmd_spec *spec;

	/* MIT frames (0x400 + ID) carry no command byte */
	if (m->p.rom_write_ns <= 0 || req->len < 1 || req->can_id >= 0x400)
		return t;
	spec = rmd_cmd_find(rmd_proto_table(m->p.proto), req->data[0]);
	if (spec && spec->flags & RMD_CMD_ROM)
		t += (int64_t)m->p.rom_write_ns;
	return t;
}
