// SPDX-License-Identifier: MIT
/*
 * The adapter between a simulated bus and the host (rmd/sim_adapter.h).
 */
#include <stdint.h>

#include "rmd/sim_adapter.h"

void rmd_sim_adapter_init(struct rmd_sim_adapter *a)
{
	a->holding = false;
	a->flush_ns = 0;
	a->packet_n = 0;
	a->packet_ns = 0;
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
	if (usb > 0 && p->adapter_rx_batch > 1) {
		/* a packet with room that has not gone yet takes the frame */
		if (a->packet_n && a->packet_n < p->adapter_rx_batch && t < a->packet_ns) {
			a->packet_n++;
		} else {
			/* a new one: it goes at the end of the USB frame after this one */
			a->packet_n = 1;
			a->packet_ns = t - t % usb + 2 * usb;
		}
		t = a->packet_ns;
	} else if (usb > 0 && t % usb) {
		/* the end of the USB frame the frame fell in (time 0 starts one) */
		t += usb - t % usb;
	}
	return t + (int64_t)p->adapter_delay_ns;
}
