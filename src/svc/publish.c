// SPDX-License-Identifier: MIT
/*
 * What the bridge publishes: state_t from the rt loop's snapshots, health_t
 * from its health and the bridge's own counters, config_t from the options
 * and the dialects bring-up found.  Each is encoded into the bridge's own
 * buffer and handed to the link (no allocation: lcm-gen's X_publish()
 * allocates).  Bridge thread (rmd/bridge.h, bridge_state.h).
 */
#include <stdint.h>
#include <stdio.h>
#include <string.h>

#include "rmd/codec.h"
#include "rmd/time.h"
#include "bridge_state.h"
#include "rmd/rmd_bus_config_t.h"
#include "rmd/rmd_bus_health_t.h"
#include "rmd/rmd_config_t.h"
#include "rmd/rmd_health_t.h"
#include "rmd/rmd_motor_config_t.h"
#include "rmd/rmd_motor_state_t.h"
#include "rmd/rmd_state_t.h"

/* The LCM constants are the C enums' values (lcm_types/ and rmd/state.h, rmd/bus.h). */
_Static_assert(RMD_STATE_T_MAX_MOTORS == RMD_MAX_MOTORS && RMD_HEALTH_T_MAX_BUSES == RMD_MAX_BUSES,
	       "array sizes");
_Static_assert(RMD_STATE_T_LC_PROBE == RMD_LC_PROBE && RMD_STATE_T_LC_READY == RMD_LC_READY &&
		       RMD_STATE_T_LC_ENABLED == RMD_LC_ENABLED &&
		       RMD_STATE_T_LC_FAULT == RMD_LC_FAULT && RMD_STATE_T_LC_LOST == RMD_LC_LOST &&
		       RMD_STATE_T_LC_SAFE == RMD_LC_SAFE &&
		       RMD_STATE_T_LC_STOPPING == RMD_LC_STOPPING && RMD_LC_COUNT == 7,
	       "lifecycle");
_Static_assert(RMD_STATE_T_POS_UNKNOWN == RMD_POS_UNKNOWN &&
		       RMD_STATE_T_POS_AMBIGUOUS == RMD_POS_AMBIGUOUS &&
		       RMD_STATE_T_POS_OUTSIDE == RMD_POS_OUTSIDE &&
		       RMD_STATE_T_POS_SAVED == RMD_POS_SAVED &&
		       RMD_STATE_T_POS_IN_BAND == RMD_POS_IN_BAND &&
		       RMD_STATE_T_POS_HOMED == RMD_POS_HOMED && RMD_POS_TRUST_COUNT == 6,
	       "position trust");
_Static_assert(RMD_HEALTH_T_WD_IDLE == RMD_WD_IDLE && RMD_HEALTH_T_WD_OK == RMD_WD_OK &&
		       RMD_HEALTH_T_WD_TRIPPED == RMD_WD_TRIPPED,
	       "watchdog");
_Static_assert(RMD_HEALTH_T_REJ_DECODE == RMD_REJ_DECODE &&
		       RMD_HEALTH_T_REJ_COUNT == RMD_REJ_COUNT &&
		       RMD_HEALTH_T_REJ_INDEX == RMD_REJ_INDEX &&
		       RMD_HEALTH_T_REJ_NONFINITE == RMD_REJ_NONFINITE &&
		       RMD_HEALTH_T_REJ_MODE == RMD_REJ_MODE &&
		       RMD_HEALTH_T_REJ_LIMIT == RMD_REJ_LIMIT &&
		       RMD_HEALTH_T_REJ_STALE == RMD_REJ_STALE &&
		       RMD_HEALTH_T_REJ_OWNER == RMD_REJ_OWNER &&
		       RMD_HEALTH_T_REJ_KINDS == RMD_REJ_KINDS,
	       "reject kinds");
_Static_assert(RMD_HEALTH_T_IGN_EDGE == RMD_IGN_EDGE &&
		       RMD_HEALTH_T_IGN_NOT_READY == RMD_IGN_NOT_READY &&
		       RMD_HEALTH_T_IGN_TRIPPED == RMD_IGN_TRIPPED &&
		       RMD_HEALTH_T_IGN_POS_UNCERTAIN == RMD_IGN_POS_UNCERTAIN &&
		       RMD_HEALTH_T_IGN_MIT_SCALING == RMD_IGN_MIT_SCALING &&
		       RMD_HEALTH_T_IGN_FIRMWARE == RMD_IGN_FIRMWARE &&
		       RMD_HEALTH_T_IGN_KINDS == RMD_IGN_KINDS,
	       "ignore kinds");
_Static_assert(RMD_BUS_HEALTH_T_BUS_ACTIVE == RMD_BUS_ACTIVE &&
		       RMD_BUS_HEALTH_T_BUS_WARNING == RMD_BUS_WARNING &&
		       RMD_BUS_HEALTH_T_BUS_PASSIVE == RMD_BUS_PASSIVE &&
		       RMD_BUS_HEALTH_T_BUS_OFF == RMD_BUS_OFF &&
		       RMD_BUS_HEALTH_T_BUS_NO_ACK == RMD_BUS_NO_ACK,
	       "bus states");
_Static_assert(RMD_MOTOR_CONFIG_T_MODE_BIT_MIT == RMD_BRIDGE_MODE_BIT(RMD_MODE_MIT) &&
		       RMD_MOTOR_CONFIG_T_MODE_BIT_TORQUE == RMD_BRIDGE_MODE_BIT(RMD_MODE_TORQUE),
	       "mode bits");

static int32_t sat32(int64_t v)
{
	return v > INT32_MAX ? INT32_MAX : v < INT32_MIN ? INT32_MIN : (int32_t)v;
}

static int64_t sat64(uint64_t v)
{
	return v > INT64_MAX ? INT64_MAX : (int64_t)v;
}

/* Encoding into our own buffer spares the allocation of the generated X_publish(). */
static bool publish_encoded(struct rmd_bridge *b, const char *channel, int n)
{
	if (n < 0 || rmd_lcm_link_publish(b->link, channel, b->buf->enc, (size_t)n) < 0) {
		bridge_count(&b->n_publish_errors);
		return false;
	}
	return true;
}

void rmd_bridge_motor_state(rmd_motor_state_t *o, unsigned index, const struct rmd_motor_state *m,
			    int64_t t_ns)
{
	*o = (rmd_motor_state_t){
		.index = (int16_t)index,
		.lifecycle = (int8_t)m->lifecycle,
		.mode = (int8_t)m->mode,
		.position = m->pos_rad,
		.velocity = m->vel_rad_s,
		.torque = m->torque_nm,
		.current = m->current_a,
		.temperature = m->temp_c,
		.voltage = m->voltage_v,
		.error_code = m->error_code,
		.reply_age_cycles = sat32(m->reply_age_cycles),
		.reply_latency_us = sat32(m->reply_latency_ns / 1000),
		.missed_replies = sat64(m->missed_replies),
		.rx_time_ns = m->rx_ns,
		.position_rx_time_ns = m->pos_rx_ns,
		.status_rx_time_ns = m->status_rx_ns,
		.position_certain = m->pos_certain,
		.position_trust = (int8_t)m->pos_trust,
		.brake_releasing = m->release_until_ns > t_ns,
	};
}

void bridge_publish_state(struct rmd_bridge *b)
{
	const struct rmd_snapshot *s;
	rmd_state_t *st = &b->buf->state;
	int n;

	if (!b->state_listeners || !b->opts.snapshots ||
	    !rmd_latest_get(b->opts.snapshots, (const void **)&s))
		return;
	if (b->state_sent && s->cycle - b->last_state_cycle < b->opts.state_every)
		return;
	b->state_sent = true;
	b->last_state_cycle = s->cycle;

	st->utime = s->t_ns / 1000;
	st->host_utime = (s->t_ns + b->rx_off_last_ns) / 1000; /* the newest drain's offset */
	st->cycle = sat64(s->cycle);
	st->owned = b->owned;
	st->owner = b->owned ? b->owner : 0;
	st->count = (int16_t)(s->n < RMD_MAX_MOTORS ? s->n : RMD_MAX_MOTORS);
	st->motor = b->buf->state_motor;
	for (int i = 0; i < st->count; i++)
		rmd_bridge_motor_state(&st->motor[i], (unsigned)i, &s->m[i], s->t_ns);
	n = rmd_state_t_encode(b->buf->enc, 0, ENC_MAX, st);
	if (publish_encoded(b, b->ch_state, n))
		bridge_count(&b->n_states);
}

void bridge_publish_health(struct rmd_bridge *b, int64_t now)
{
	static const struct rmd_health none;
	const struct rmd_health *h = &none;
	rmd_health_t *o = &b->buf->health;
	int n;

	if (b->opts.health)
		rmd_latest_get(b->opts.health, (const void **)&h);
	/* bring-up found a motor's dialect or firmware (protocol auto): config_t says it again */
	for (unsigned i = 0; i < h->nmotors && i < b->opts.nmotors; i++)
		if (h->proto[i] != b->config_proto[i] || h->firmware[i] != b->config_firmware[i])
			b->config_wanted = true;
	o->utime = now / 1000;
	o->instance = b->opts.instance;
	o->host = b->opts.host;
	o->pid = b->opts.pid;
	o->foreign_messages = sat64(bridge_counted(&b->n_foreign));
	o->foreign_instance = b->foreign.instance;
	o->foreign_host = b->foreign.host;
	o->foreign_pid = b->foreign.pid;
	o->cycles = sat64(h->loop.cycles);
	o->overruns = sat64(h->loop.overruns);
	o->plan_misses = sat64(h->loop.plan_misses);
	o->wake_min_us = h->loop.wake_min_ns / 1e3;
	o->wake_avg_us = h->loop.wake_avg_ns / 1e3;
	o->wake_p99_us = h->loop.wake_p99_ns / 1e3;
	o->wake_max_us = h->loop.wake_max_ns / 1e3;
	o->cycle_max_us = h->loop.cycle_max_ns / 1e3;
	o->bus_count = (int16_t)(h->nbuses < RMD_MAX_BUSES ? h->nbuses : RMD_MAX_BUSES);
	for (int i = 0; i < RMD_MAX_BUSES; i++) {
		const struct rmd_bus_health *bh = &h->bus[i];
		rmd_bus_health_t *ob = &o->bus[i];
		char *name = b->buf->bus_name[i];

		if (i >= o->bus_count) {
			name[0] = '\0';
			*ob = (rmd_bus_health_t){ .name = name };
			continue;
		}
		/* The rt loop's name, else the configured one; never unterminated. */
		snprintf(name, RMD_BRIDGE_NAME_LEN, "%.*s", (int)sizeof(bh->name),
			 bh->name[0] ? bh->name :
				       ((unsigned)i < b->opts.nbuses ? b->opts.bus[i].name : ""));
		ob->name = name;
		ob->state = (int8_t)bh->state;
		ob->load = bh->load;
		ob->tx_frames = sat64(bh->stats.tx_frames);
		ob->rx_frames = sat64(bh->stats.rx_frames);
		ob->tx_busy = sat64(bh->stats.tx_busy);
		ob->rx_errors = sat64(bh->stats.rx_errors);
		ob->bus_errors = sat64(bh->stats.bus_errors);
		ob->state_changes = sat64(bh->stats.state_changes);
	}
	o->watchdog = (int8_t)h->watchdog;
	o->safe_action_events = sat64(h->safe_action_events);

	/* The bridge is the one that counts commands. */
	o->commands_accepted = sat64(bridge_counted(&b->n_accepted));
	o->commands_rejected = 0;
	for (int k = 0; k < RMD_REJ_KINDS; k++) {
		o->rejected_by_kind[k] = sat64(bridge_counted(&b->n_rejected[k]));
		o->commands_rejected += o->rejected_by_kind[k];
	}
	o->commands_clamped = sat64(bridge_counted(&b->n_clamped));
	for (int k = 0; k < RMD_IGN_KINDS; k++)
		o->ignored_by_kind[k] = sat64(h->ignored[k]);
	o->homes_refused = sat64(h->homes_refused);
	o->owned = b->owned;
	o->owner = b->owned ? b->owner : 0;
	o->intruder = atomic_load_explicit(&b->pub_intruder, memory_order_relaxed);
	o->takeovers = sat64(bridge_counted(&b->n_takeovers));
	/*
	 * Every configured motor, always (config_t's count): before the loop's
	 * first health its entries read "pending", and a C subscriber never
	 * decodes an empty int8_t array (LCM 1.3.1's generated decode passes
	 * NULL to memcpy for one).
	 */
	o->motor_count =
		(int16_t)(b->opts.nmotors < RMD_MAX_MOTORS ? b->opts.nmotors : RMD_MAX_MOTORS);
	o->comm_loss = b->buf->health_cl;
	o->comm_loss_ms = b->buf->health_cl_ms;
	o->unarmed_rejects = b->buf->health_unarmed;
	for (int i = 0; i < o->motor_count; i++) {
		bool known = (unsigned)i < h->nmotors;

		o->comm_loss[i] = known ? (int8_t)h->comm_loss[i] : 0;
		o->comm_loss_ms[i] = known ? sat32(h->comm_loss_ms[i]) : 0;
		o->unarmed_rejects[i] = known ? sat64(h->unarmed_rejects[i]) : 0;
	}

	bridge_robot_health(b, now, o);
	n = rmd_health_t_encode(b->buf->enc, 0, ENC_MAX, o);
	if (publish_encoded(b, b->ch_health, n))
		bridge_count(&b->n_health);
}

void bridge_publish_config(struct rmd_bridge *b)
{
	struct rmd_bridge_opts *op = &b->opts;
	rmd_config_t *c = &b->buf->config;
	static const struct rmd_health none;
	const struct rmd_health *h = &none;

	c->utime = rmd_now_ns() / 1000;
	c->prefix = op->prefix;
	c->version = op->version;
	c->instance = op->instance;
	c->host = op->host;
	c->pid = op->pid;
	c->source = op->source;
	c->instance_name = op->robot.instance;
	c->n_peers = (int16_t)op->robot.n_peers;
	c->peers = b->buf->config_peers;
	for (unsigned i = 0; i < op->robot.n_peers && i < RMD_CONFIG_MAX_PEERS; i++)
		c->peers[i] = op->robot.peers[i];
	c->period_us = sat32(op->period_ns / 1000);
	c->state_every = sat32(op->state_every);
	c->stale_ms = op->stale_ms;
	c->bus_count = (int16_t)op->nbuses;
	c->bus = b->buf->config_bus;
	for (unsigned i = 0; i < op->nbuses; i++) {
		c->bus[i].name = op->bus[i].name;
		c->bus[i].kind = op->bus[i].kind;
		c->bus[i].bitrate = sat32(op->bus[i].bitrate);
	}
	c->motor_count = (int16_t)op->nmotors;
	c->motor = b->buf->config_motor;
	/* the protection's state and time come from the loop's newest health */
	if (op->health)
		rmd_latest_get(op->health, (const void **)&h);
	for (unsigned i = 0; i < h->nmotors && i < RMD_MAX_MOTORS; i++) {
		b->config_proto[i] = h->proto[i];
		b->config_firmware[i] = h->firmware[i];
	}
	for (unsigned i = 0; i < op->nmotors; i++) {
		const struct rmd_motor_info *m = &op->motor[i];

		c->motor[i] = (rmd_motor_config_t){
			.index = (int16_t)i,
			.name = op->motor[i].name,
			.bus = m->bus,
			.id = m->id,
			/* bring-up's answer for protocol auto, and the firmware date */
			.protocol = i < h->nmotors ?
					    (char *)rmd_proto_key((enum rmd_proto)h->proto[i]) :
					    op->motor[i].protocol,
			.firmware = i < h->nmotors ? sat32(h->firmware[i]) : 0,
			.modes = (int8_t)m->modes,
			.position_min = m->pos_min_rad,
			.position_max = m->pos_max_rad,
			.velocity_max = m->vel_max_rad_s,
			.torque_max = m->torque_max_nm,
			.kp_min = m->kp_min,
			.kp_max = m->kp_max,
			.kd_min = m->kd_min,
			.kd_max = m->kd_max,
			.comm_loss_ms = i < h->nmotors ? sat32(h->comm_loss_ms[i]) : -1,
			.comm_loss = i < h->nmotors ? (int8_t)h->comm_loss[i] : 0,
			.position_resolution = m->pos_resolution_rad,
			.position_rate_hz = m->pos_rate_hz,
			.multi_turn_saved = m->multi_turn_saved,
			.travel_min = m->travel_min_rad,
			.travel_max = m->travel_max_rad,
			.turn_period = m->turn_period_rad,
		};
	}
	/*
	 * Encoded once: the bytes published are the ones rmd_bridge_config_copy()
	 * hands out.  Only this thread writes them, so reading them unlocked
	 * here is safe; the lock keeps a copier from seeing them half-written.
	 */
	pthread_mutex_lock(&b->config_mu);
	b->buf->config_len = rmd_config_t_encode(b->buf->config_enc, 0, ENC_MAX, c);
	pthread_mutex_unlock(&b->config_mu);
	if (b->buf->config_len < 0 ||
	    rmd_lcm_link_publish(b->link, b->ch_config, b->buf->config_enc,
				 (size_t)b->buf->config_len) < 0)
		bridge_count(&b->n_publish_errors);
	else
		bridge_count(&b->n_configs);
}
