// SPDX-License-Identifier: MIT
/*
 * rmd-sim's event loop: simulated motors behind a real wire.
 *
 * One thread, one epoll set: the wire (a SocketCAN interface or a serial
 * line, opened, read and written through the bus layer's transport in its
 * device role: the motors' side), a timerfd on CLOCK_MONOTONIC and a
 * signalfd for SIGINT/SIGTERM.
 * Motor time is CLOCK_MONOTONIC in ns.
 *
 * - The motors, their frames by due time and what fault windows do to them
 *   are a node (rmd/sim_node.h), the one the in-process wire runs: a frame
 *   that arrives goes to every present motor at its arrival time
 *   (rmd_sim_node_receive()); each reply is due a turnaround later, never
 *   before that motor's previous reply, and when the host's adapter would
 *   hand it on (RMD_SIM_NODE_HOST_ADAPTER); unsolicited frames (0xF1, 0x9A
 *   reports) are due when the motor says (rmd_sim_node_poll()).
 * - The timer is armed for the earliest of: the queue's head, the motors'
 *   next unsolicited frame, a fault window's edge, a flood frame, a write
 *   retry, the physics tick (every motor stepped every 10 ms, so a long
 *   quiet spell never costs a long catch-up) and the once-a-second check of
 *   the CAN interface's state.
 * - A write that the kernel refuses for lack of room (ENOBUFS from a CAN
 *   queue of txqueuelen frames, EAGAIN) is counted and retried 200 µs later,
 *   in order; it is never fatal.
 * - SIGINT/SIGTERM: the requests read before it, and those already on the
 *   line, are answered at their due time (up to FINISH_NS), then it stops.
 *
 * Faults are struct rmd_sim_fault entries, with the semantics of
 * rmd/sim_wire.h where they apply to a real wire (the node's: the same code):
 * per-frame kinds act on each frame a motor makes, in table order, a drop
 * ending the list; DISAPPEAR and ERROR_FLAG act over their window; FLOOD
 * writes a foreign frame every period (CAN only); BUS_OFF is refused by the
 * config (the kernel owns a real bus's state).
 *
 * The motors speak CAN identifiers on both wires: on an RS485 line the
 * transport's device role gives each frame its RS485 form both ways (V3
 * §1.2.2, §6, §7: rmd/bus_rs485.h), and the log shows that form
 * (rmd_rs485_from_can()).
 *
 * Non-rt: a normal process; it logs from the loop.
 */
#define _GNU_SOURCE

#include <errno.h>
#include <inttypes.h>
#include <limits.h>
#include <poll.h>
#include <signal.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <time.h>
#include <unistd.h>

#include <net/if.h>
#include <sys/epoll.h>
#include <sys/ioctl.h>
#include <sys/prctl.h>
#include <sys/signalfd.h>
#include <sys/timerfd.h>

#include "rmd/time.h"
#include "rmd/bus.h"
#include "rmd/bus_open.h"
#include "rmd/bus_rs485.h"
#include "rmd/codec.h"
#include "rmd/describe.h"
#include "rmd/rs485.h"
#include "rmd/sim.h"
#include "rmd/sim_body.h"
#include "rmd/sim_faults.h"
#include "rmd/sim_node.h"
#include "rmd-sim.h"

#define TXQ 1024			/* frames waiting for their due time */
#define TICK_NS (10 * RMD_NS_PER_MS)	/* physics step of idle motors */
#define HOUSEKEEPING_NS RMD_NS_PER_S	/* CAN interface state check */
#define RETRY_NS (200 * RMD_NS_PER_US)	/* after ENOBUFS / EAGAIN */
#define MAX_READS 256			/* frames read per wake-up, then timers */
#define RX_BATCH 64			/* frames per rmd_bus_recv() */
#define FINISH_NS (250 * RMD_NS_PER_MS) /* SIGINT/SIGTERM: replies still due go out within */
/* Steps of the world slower than real time so many times in a row: said (once may be a hiccup). */
#define BEHIND_RUN 3
/*
 * With physics, the world's present (rmd-sim's clock less the slip) stays
 * within this of the time the world was last stepped to; what a step took
 * beyond it is added to the slip.  A model slower than real time then runs
 * slower than real time, instead of every frame stepping the whole backlog.
 */
#define SLIP_AFTER_NS (2 * TICK_NS)

/* What the node (its stats: queue overflows, frames lost while absent, faults) does not count. */
struct stats {
	uint64_t rx_frames;  /* frames received (serial: valid frames) */
	uint64_t rx_taken;   /* ... that at least one motor answered */
	uint64_t tx_frames;  /* frames written */
	uint64_t tx_busy;    /* writes refused for lack of room, retried */
	uint64_t tx_errors;  /* writes that failed otherwise (frame lost) */
	uint64_t rx_errors;  /* read errors */
	uint64_t unmappable; /* frames with no RS485 form */
	uint64_t unsent;     /* frames still waiting when rmd-sim stopped */
	uint64_t behind;     /* steps of the world slower than real time */
	int64_t behind_max_ns;
	uint64_t slips;	     /* times the world fell further behind real time (slip_ns) */
	unsigned behind_run; /* behind so many times in a row */
	bool behind_warned;
};

struct sim {
	const struct sim_config *cfg;
	struct rmd_sim_body *body; /* sim.physics (rmd/sim_body.h); NULL: none */
	struct rmd_bus bus;	   /* the wire (ops set once open) */
	const char *name;	   /* the wire, for messages */
	int64_t t0;
	/* The motors and their frames waiting in q[] for their due time; fault times since t0. */
	struct rmd_sim_node node;
	struct rmd_sim_pending q[TXQ];
	int64_t motors_ns; /* a motor's next unsolicited frame (rmd_sim_node_poll()) */
	int64_t retry_ns;  /* 0: the head may be written now */
	bool overflow_warned;

	int fd, epfd, tfd, sfd;
	bool serial;
	bool if_down;
	uint32_t ep_events; /* what the wire fd is registered for */

	uint64_t noise_seen; /* serial: the bus's rx_noise_bytes already reported */
	bool noise_warned;

	int64_t next_tick_ns, next_house_ns;
	/*
	 * With physics: the time the world was last stepped to (a tick, a
	 * frame), and how far the world runs behind real time.  The motors'
	 * times (the node's, a frame's arrival, a reply's due time, a fault's
	 * window) are world times: rmd-sim's clock less slip_ns (world()).
	 */
	int64_t world_ns, slip_ns;
	/* ... when the last step ended (rmd-sim's clock), and what steps cost: wall ns, world ns */
	int64_t step_end_ns;
	double cost_took, cost_span;
	uint64_t tx_errors_logged;
	struct stats st;
	int status;	 /* exit status once stopping */
	const char *why; /* why we stop */
	bool stop;
	bool gone; /* the line hung up, or the interface was removed */
};

/* ---- logging of frames ----------------------------------------------------------------- */

/* The motor whose current ID is `id`, or NULL. */
static const struct rmd_sim_motor *motor_by_can_id(const struct sim *s, unsigned id)
{
	for (unsigned i = 0; i < s->node.n_motors; i++)
		if (s->node.motors[i].ram.can_id == id)
			return &s->node.motors[i];
	return NULL;
}

/* How to decode a request with identifier can_id: the addressed motor's protocol. */
static enum rmd_proto request_proto(struct sim *s, uint32_t can_id,
				    const struct rmd_mit_ranges **mit)
{
	const struct rmd_sim_motor *m = NULL;

	*mit = NULL;
	if (can_id > RMD_CAN_REQ_BASE && can_id <= RMD_CAN_REQ_BASE + RMD_MAX_MOTORS)
		m = motor_by_can_id(s, can_id - RMD_CAN_REQ_BASE);
	else if (can_id > RMD_CAN_MIT_REQ_BASE && can_id <= RMD_CAN_MIT_REQ_BASE + RMD_MAX_MOTORS)
		m = motor_by_can_id(s, can_id - RMD_CAN_MIT_REQ_BASE);
	else if (can_id == RMD_CAN_MULTI && s->node.n_motors)
		m = &s->node.motors[0];
	if (!m)
		return RMD_PROTO_V3;
	/* V3 §5, V4.2 §5: its firmware takes MIT frames; its others are its table's */
	if (can_id > RMD_CAN_MIT_REQ_BASE && rmd_dialect_offers_mit(m->d)) {
		*mit = &m->mit_ranges;
		return RMD_PROTO_MIT;
	}
	return m->d->table;
}

static void hex(char *buf, size_t size, const uint8_t *b, size_t n)
{
	size_t k = 0;

	buf[0] = '\0';
	for (size_t i = 0; i < n && k + 4 < size; i++)
		k += (size_t)snprintf(buf + k, size - k, "%s%02X", i ? " " : "", b[i]);
}

/* A frame for -v (rmd/describe.h), and the simulator's own 0xF1 comm-loss notice. */
static void describe(char *buf, size_t size, enum rmd_proto proto, enum rmd_dir dir,
		     const struct rmd_mit_ranges *mit, const struct rmd_frame *f)
{
	if (rmd_describe_frame(buf, size, proto, dir, mit, f) < 0 && dir == RMD_DIR_REPLY &&
	    f->len >= 1 && f->data[0] == RMD_SIM_CMD_COMM_LOST)
		snprintf(buf, size, "comm_lost (0xF1, unsolicited)");
}

static void log_rx(struct sim *s, const struct rmd_frame *f, int answers)
{
	char desc[512], data[32];
	const struct rmd_mit_ranges *mit;
	enum rmd_proto proto;

	if (!tool_log_enabled(TOOL_LOG_DEBUG))
		return;
	proto = request_proto(s, f->can_id, &mit);
	describe(desc, sizeof(desc), proto, RMD_DIR_REQUEST, mit, f);
	hex(data, sizeof(data), f->data, f->len);
	if (s->serial)
		tool_log(TOOL_LOG_DEBUG,
			 "rmd-sim: %s: rx id 0x%02X [%u] %s  (0x%03X) %s; %d repl%s", s->name,
			 (unsigned)rmd_rs485_id_of_can(f->can_id, true), f->len, data, f->can_id,
			 desc, answers, answers == 1 ? "y" : "ies");
	else
		tool_log(TOOL_LOG_DEBUG, "rmd-sim: %s: rx %03X [%u] %s  %s; %d repl%s", s->name,
			 f->can_id, f->len, data, desc, answers, answers == 1 ? "y" : "ies");
}

/* e: the frame as scheduled and written; on a line its RS485 form (rmd_rs485_from_can()). */
static void log_tx(struct sim *s, const struct rmd_sim_pending *e)
{
	char desc[512], data[32], who[32];
	const struct rmd_mit_ranges *mit = NULL;
	enum rmd_proto proto = RMD_PROTO_V3;
	struct rmd_frame as_sent = e->f;
	const struct rmd_frame *wire = &as_sent;
	int rs485_id = 0;

	if (!tool_log_enabled(TOOL_LOG_DEBUG))
		return;
	if (s->serial)
		rs485_id = rmd_rs485_from_can(&e->f, false, &as_sent);
	if (e->src >= 0) {
		const struct rmd_sim_motor *m = &s->node.motors[e->src];

		mit = &m->mit_ranges;
		/* its MIT replies on 0x500 + ID (V3 §5), its others its table's */
		proto = e->f.can_id > RMD_CAN_MIT_REPLY_BASE &&
					e->f.can_id <= RMD_CAN_MIT_REPLY_BASE + RMD_MAX_MOTORS ?
				RMD_PROTO_MIT :
				m->d->table;
		snprintf(who, sizeof(who), "motor %u", m->p.id);
		describe(desc, sizeof(desc), proto, RMD_DIR_REPLY, mit, wire);
	} else {
		snprintf(who, sizeof(who), "flood");
		snprintf(desc, sizeof(desc), "(foreign frame)");
	}
	hex(data, sizeof(data), wire->data, wire->len);
	if (s->serial)
		tool_log(TOOL_LOG_DEBUG, "rmd-sim: %s: tx id 0x%02X [%u] %s  (0x%03X) %s: %s",
			 s->name, (unsigned)rs485_id, wire->len, data, e->f.can_id, who, desc);
	else
		tool_log(TOOL_LOG_DEBUG, "rmd-sim: %s: tx %03X [%u] %s  %s: %s", s->name,
			 e->f.can_id, e->f.len, data, who, desc);
}

/* ---- the motors (rmd/sim_node.h) ----------------------------------------------------------- */

/* The first overflow of the queue of due frames, warned once. */
static void note_overflow(struct sim *s)
{
	if (!s->node.stats.dropped || s->overflow_warned)
		return;
	s->overflow_warned = true;
	tool_log(TOOL_LOG_WARNING,
		 "rmd-sim: %s: more than %d frames waiting to be sent; dropping "
		 "(counted in the exit summary)",
		 s->name, TXQ);
}

/* Open/close fault windows at now, said in the log; flood frames that fell due. */
static void update_faults(struct sim *s, int64_t now)
{
	const struct sim_config *c = s->cfg;
	struct rmd_sim_node_change ch;

	if (rmd_sim_node_update(&s->node, now, &ch)) {
		for (unsigned k = 0; k < s->node.faults.n; k++)
			if ((ch.windows >> k) & 1)
				tool_log(TOOL_LOG_NOTICE, "rmd-sim: fault \"%s\" %s at %.3f s",
					 c->fault_text[k],
					 s->node.faults.open[k] ? "begins" : "ends",
					 (double)(now - s->t0) / 1e9);
		for (unsigned i = 0; i < s->node.n_motors; i++) {
			unsigned id = s->node.motors[i].p.id;

			if ((ch.power_off >> i) & 1)
				tool_log(TOOL_LOG_INFO, "rmd-sim: motor %u loses power", id);
			if ((ch.power_on >> i) & 1)
				tool_log(TOOL_LOG_INFO, "rmd-sim: motor %u powered again: boots",
					 id);
		}
	}
	rmd_sim_node_queue_floods(&s->node, now);
	note_overflow(s);
}

/* The world's time at rmd-sim's clock `wall`: the same without physics. */
static int64_t world(const struct sim *s, int64_t wall)
{
	return wall - s->slip_ns;
}

/*
 * The world (sim.physics) was stepped up to a frame's arrival, or through
 * a tick, and that took late_ns of real time, longer than the world time
 * it stepped: the model runs slower than real time on this machine: said once
 * BEHIND_RUN in a row were (the world falls behind real time, replies may
 * be late), counted in the summary.  late_ns 0: on time, which ends a run.
 */
static void note_behind(struct sim *s, int64_t late_ns, const char *how)
{
	if (!late_ns) {
		s->st.behind_run = 0;
		return;
	}
	s->st.behind++;
	if (++s->st.behind_run >= BEHIND_RUN && !s->st.behind_warned) {
		s->st.behind_warned = true;
		tool_log(TOOL_LOG_WARNING,
			 "rmd-sim: %s: physics: the model steps slower than real time here (%s "
			 "%.1f ms): the world falls behind real time (its motion slower than the "
			 "clocks say) and replies may be late; lower sim.physics.rate_hz or "
			 "substeps, or run on a faster machine (docs/physics.md \"Time and rate\"; "
			 "counted in the exit summary)",
			 s->name, how, (double)late_ns / 1e6);
	}
	if (late_ns > s->st.behind_max_ns)
		s->st.behind_max_ns = late_ns;
}

/*
 * With physics, the world time up to which the world may be stepped now,
 * asked for t: at most two ticks past where it is, and for a tick
 * (`budget`) no more than the time since the last step ended buys at what
 * steps cost lately -- the model then takes at most about half of
 * rmd-sim's time, and the frames are answered in the other half.  The
 * world falls behind real time by the rest (the slip), so world(t) is what
 * this returns.  Without this a model slower than real time made every
 * frame step the world through all the time since the last, longer each
 * time (measured in the TCG guest: replies 0.2-1.1 s late, rmdd lost both
 * motors of the leg).
 */
static int64_t may_step_to(struct sim *s, int64_t t, bool budget)
{
	int64_t span = t - s->world_ns, allowed = 2 * TICK_NS;

	if (!s->body || span <= 0)
		return t;
	if (budget && s->cost_took > 0) {
		double buys = (double)(rmd_now_ns() - s->step_end_ns) * s->cost_span / s->cost_took;

		if (buys < (double)allowed)
			allowed = buys > 0 ? (int64_t)buys : 0;
	}
	if (span > allowed) {
		s->slip_ns += span - allowed;
		s->st.slips++;
		t = s->world_ns + allowed;
	}
	return t;
}

/*
 * With physics, the world was stepped to t, from rmd-sim's clock `from` on:
 * what it cost, into the recent cost (decaying), and where the world is.
 * A step that took longer than real time allows leaves the world behind by
 * the rest (SLIP_AFTER_NS): the frames that waited meanwhile then lie in
 * the world's past, and are answered without stepping it again.
 */
static void stepped_to(struct sim *s, int64_t t, int64_t from)
{
	int64_t now = rmd_now_ns(), ahead;

	if (!s->body || t <= s->world_ns)
		return;
	/* slower than real time: it took longer than the world time it stepped */
	note_behind(s, now - from > t - s->world_ns ? now - from : 0,
		    "a step took longer than the world time it stepped:");
	s->cost_took = s->cost_took * 0.875 + (double)(now - from);
	s->cost_span = s->cost_span * 0.875 + (double)(t - s->world_ns);
	s->world_ns = t;
	s->step_end_ns = now;
	ahead = world(s, now) - s->world_ns;
	if (ahead > SLIP_AFTER_NS) {
		s->slip_ns += ahead - SLIP_AFTER_NS;
		s->st.slips++;
	}
}

/* A frame arrived at rmd-sim's clock t: every present motor sees it.  Returns the replies they made. */
static int deliver(struct sim *s, const struct rmd_frame *f, int64_t t)
{
	int64_t from = rmd_now_ns(), w = may_step_to(s, world(s, t), false);
	int n = rmd_sim_node_receive(&s->node, f, w, RMD_SIM_SRC_HOST);

	stepped_to(s, w, from);
	note_overflow(s);
	return n;
}

/* The physics tick, and unsolicited frames due by now (rmd-sim's clock). */
static void run_motors(struct sim *s, int64_t wall)
{
	int64_t now = world(s, wall);

	if (now >= s->next_tick_ns) {
		int64_t from = rmd_now_ns(), to;

		/*
		 * A model slower than real time: a tick that stepped the world
		 * through all the time since the last would take longer each
		 * time (each tick's time is the last one's times the slowness),
		 * and rmd-sim would neither say so nor heed SIGTERM.  A tick
		 * steps what may_step_to() allows; the world falls behind
		 * real time by the rest (counted by note_behind).
		 */
		to = may_step_to(s, now, true);
		rmd_sim_node_step(&s->node, to);
		stepped_to(s, to, from);
		s->next_tick_ns = to + TICK_NS;
	}
	s->motors_ns = rmd_sim_node_poll(&s->node, world(s, wall));
	note_overflow(s);
}

/* ---- the CAN wire ---------------------------------------------------------------------- */

static void set_down(struct sim *s, bool down, const char *how)
{
	if (down == s->if_down)
		return;
	s->if_down = down;
	if (down)
		tool_log(TOOL_LOG_WARNING,
			 "rmd-sim: %s: interface is down (%s); frames are lost "
			 "until it is up",
			 s->name, how);
	else
		tool_log(TOOL_LOG_NOTICE, "rmd-sim: %s: interface is up again", s->name);
}

static void stop(struct sim *s, int status, const char *why)
{
	if (s->stop)
		return;
	s->stop = true;
	s->status = status;
	s->why = why;
}

/* Is the interface up?  Stops the program when it was removed. */
static void check_interface(struct sim *s)
{
	struct ifreq ifr;

	memset(&ifr, 0, sizeof(ifr));
	snprintf(ifr.ifr_name, sizeof(ifr.ifr_name), "%s", s->name);
	if (ioctl(s->fd, SIOCGIFFLAGS, &ifr) < 0) {
		if (errno == ENODEV) {
			tool_log(TOOL_LOG_ERR, "rmd-sim: %s: the interface was removed", s->name);
			s->gone = true;
			stop(s, SIM_EXIT_RUN, "the interface was removed");
		}
		return;
	}
	set_down(s, !(ifr.ifr_flags & IFF_UP), "flags");
}

/* The interface, through the bus layer's SocketCAN transport on the motors' side.  Non-rt. */
static int can_open(struct sim *s)
{
	struct rmd_bus_open_opts o = { .proto = RMD_PROTO_V3, .device = true };
	char err[512];
	int r;

	r = rmd_bus_open_spec(&s->bus, s->name, &o, err, sizeof(err));
	if (r < 0) {
		tool_log(TOOL_LOG_ERR, "rmd-sim: %s", err[0] ? err : strerror(-r));
		return r;
	}
	s->fd = rmd_bus_fd(&s->bus);
	check_interface(s);
	return 0;
}

/* ---- the serial wire ------------------------------------------------------------------- */

/* The line, through the bus layer's RS485 transport on the motors' side.  Non-rt. */
static int serial_open(struct sim *s)
{
	struct rmd_bus_open_opts o = {
		.proto = RMD_PROTO_V3,
		.baud = s->cfg->baud,
		.local_echo = s->cfg->local_echo,
		.device = true,
	};
	char spec[PATH_MAX + sizeof(s->cfg->device)], err[512];
	int r;

	/* A bus spec names a serial line by an absolute path. */
	if (s->name[0] == '/' || !getcwd(spec, PATH_MAX))
		snprintf(spec, sizeof(spec), "%s", s->name);
	else
		snprintf(spec + strlen(spec), sizeof(spec) - strlen(spec), "/%s", s->name);
	r = rmd_bus_open_spec(&s->bus, spec, &o, err, sizeof(err));
	if (r < 0) {
		tool_log(TOOL_LOG_ERR, "rmd-sim: %s", err[0] ? err : strerror(-r));
		return r;
	}
	/* A notice says the port has no kernel RS485 mode (a pty, a USB adapter). */
	if (err[0])
		tool_log(TOOL_LOG_INFO,
			 "rmd-sim: %s: no kernel RS485 mode (a pseudo-terminal, or an adapter that "
			 "switches direction by itself)",
			 s->name);
	else
		tool_log(TOOL_LOG_INFO, "rmd-sim: %s: kernel RS485 mode on", s->name);
	s->fd = rmd_bus_fd(&s->bus);
	return 0;
}

/* Line noise the transport skipped since the last look: warned once, then at debug level. */
static void note_noise(struct sim *s)
{
	uint64_t noise = rmd_bus_stats(&s->bus)->rx_noise_bytes;
	uint64_t skipped = noise - s->noise_seen;

	if (!skipped)
		return;
	s->noise_seen = noise;
	tool_log(s->noise_warned ? TOOL_LOG_DEBUG : TOOL_LOG_WARNING,
		 "rmd-sim: %s: skipped %" PRIu64 " byte%s of line noise to resynchronise%s",
		 s->name, skipped, skipped == 1 ? "" : "s",
		 s->noise_warned ? "" : " (further noise is counted in the exit summary)");
	s->noise_warned = true;
}

/* ---- reading the wire ------------------------------------------------------------------ */

/* A read error.  Returns true when reading may go on. */
static bool read_error(struct sim *s, int n)
{
	if (s->serial) {
		/* EIO, or end of file with a hang-up: the other side closed the line. */
		tool_log(TOOL_LOG_ERR, "rmd-sim: %s: hang-up: the line was closed (%s)", s->name,
			 n < 0 ? strerror(-n) : "end of file");
		s->gone = true;
		stop(s, SIM_EXIT_RUN, "hang-up");
		return false;
	}
	if (n == -EAGAIN || n == -EINTR)
		return false;
	if (n == -ENETDOWN) {
		set_down(s, true, "read: ENETDOWN");
		return true;
	}
	if (n == -ENODEV) {
		tool_log(TOOL_LOG_ERR, "rmd-sim: %s: the interface was removed", s->name);
		s->gone = true;
		stop(s, SIM_EXIT_RUN, "the interface was removed");
		return false;
	}
	if (!s->st.rx_errors++)
		tool_log(TOOL_LOG_WARNING, "rmd-sim: %s: read: %s", s->name, strerror(-n));
	return false;
}

/* Requests that arrived go to the motors; hup: the line was hung up (serial). */
static void wire_read(struct sim *s, bool hup)
{
	struct rmd_bus_rx rx[RX_BATCH];

	for (unsigned i = 0; i < MAX_READS;) {
		int n = rmd_bus_recv(&s->bus, rx, RX_BATCH, rmd_now_ns());

		if (n < 0 || (n == 0 && hup)) {
			if (!read_error(s, n))
				return;
			i++;
			continue;
		}
		for (int k = 0; k < n; k++) {
			int answers;

			set_down(s, false, "");
			s->st.rx_frames++;
			answers = deliver(s, &rx[k].f, rx[k].t_ns);
			if (answers)
				s->st.rx_taken++;
			log_rx(s, &rx[k].f, answers);
		}
		note_noise(s);
		if (n < RX_BATCH)
			return;
		i += (unsigned)n;
	}
}

/* ---- writing due frames ---------------------------------------------------------------- */

/*
 * Write one frame through the transport's device role, which gives it its
 * form on the wire (on a line: rmd_rs485_from_can()): 0, -EAGAIN to retry
 * later, -EINVAL when the wire has no form for it, or -errno when it is lost.
 */
static int wire_write(struct sim *s, const struct rmd_frame *f)
{
	int r = rmd_bus_send(&s->bus, f, 1, rmd_now_ns());

	if (r == -ENETDOWN) {
		/* A socket keeps the ENETDOWN of a link that went down: once up, it is stale. */
		check_interface(s);
		if (!s->if_down)
			r = rmd_bus_send(&s->bus, f, 1, rmd_now_ns());
	}
	if (r == 1) {
		set_down(s, false, "");
		return 0;
	}
	if (r == 0) /* ENOBUFS or EAGAIN: no room */
		return -EAGAIN;
	if (r == -ENETDOWN)
		set_down(s, true, "write: ENETDOWN");
	return r < 0 ? r : -EIO;
}

/* A write that failed with r (-errno): frames lost, logged at 1, 3, 7, ... */
static void tx_lost(struct sim *s, int r)
{
	s->st.tx_errors++;
	if (s->st.tx_errors >= s->tx_errors_logged * 2 + 1) {
		tool_log(TOOL_LOG_WARNING,
			 "rmd-sim: %s: write: %s (%" PRIu64 " frames "
			 "lost so far)",
			 s->name, strerror(-r), s->st.tx_errors);
		s->tx_errors_logged = s->st.tx_errors;
	}
}

/* Replies the transport holds (a line's bytes the tty refused): the wire is writable again. */
static void wire_flush(struct sim *s)
{
	int r = rmd_bus_send(&s->bus, NULL, 0, rmd_now_ns());

	if (r < 0)
		tx_lost(s, r);
}

static void write_due(struct sim *s, int64_t now)
{
	if (s->retry_ns && now < s->retry_ns)
		return;
	s->retry_ns = 0;
	for (const struct rmd_sim_pending *h;
	     (h = rmd_sim_node_head(&s->node)) && h->ready_ns <= now;) {
		struct rmd_sim_pending e = *h;
		int r = wire_write(s, &e.f);

		if (r == -EAGAIN) {
			s->st.tx_busy++;
			s->retry_ns = now + RETRY_NS;
			break;
		}
		rmd_sim_node_take(&s->node, 0);
		if (r == -EINVAL) {
			s->st.unmappable++;
			if (tool_log_enabled(TOOL_LOG_DEBUG))
				tool_log(TOOL_LOG_DEBUG,
					 "rmd-sim: %s: 0x%03X has no RS485 form; not sent", s->name,
					 e.f.can_id);
			continue;
		}
		if (r < 0) {
			tx_lost(s, r);
			continue;
		}
		s->st.tx_frames++;
		log_tx(s, &e);
	}
}

/* ---- stopping ------------------------------------------------------------------------- */

/* The earliest due time of the motors' frames in the queue (INT64_MAX: none); *n: how many. */
static int64_t replies_due(const struct sim *s, unsigned *n)
{
	int64_t t = INT64_MAX;

	*n = 0;
	for (unsigned i = 0; i < s->node.qn; i++) {
		if (s->node.q[i].src < 0)
			continue;
		(*n)++;
		if (s->node.q[i].ready_ns < t)
			t = s->node.q[i].ready_ns;
	}
	return t;
}

/*
 * Stopping on SIGINT/SIGTERM: the requests that reached the line before it
 * are answered, each reply written at its due time, as the motors would
 * before the power went; what is due more than FINISH_NS after the signal,
 * or what the line does not take by then, is counted unsent.  Without this
 * a request read in the wake-up that also brought the signal counted as
 * answered while its reply, still in its turnaround, was dropped: on a busy
 * machine the summary read like lost replies ("answered 88, out 84").
 */
static void finish(struct sim *s)
{
	int64_t end = world(s, rmd_now_ns()) + FINISH_NS; /* the world's times, as the replies' */
	bool held = false; /* replies the transport holds (a line's bytes the tty has not taken) */
	unsigned n;

	if (s->gone) /* in the same wake-up as the signal: nothing to read or write */
		return;
	wire_read(s, false);
	if (s->gone)
		return;
	for (;;) {
		int64_t now = world(s, rmd_now_ns()), next = end, due;
		struct pollfd p = { .fd = s->fd, .events = 0 };
		struct timespec ts;

		write_due(s, now);
		due = replies_due(s, &n);
		held = rmd_bus_next_due_ns(&s->bus) != INT64_MAX;
		if ((!n && !held) || now >= end)
			break;
		if (n) {
			if (s->retry_ns > due)
				due = s->retry_ns;
			if (due < next)
				next = due;
		}
		if (held)
			p.events = POLLOUT;
		ts.tv_sec = (time_t)((next - now) / RMD_NS_PER_S);
		ts.tv_nsec = (long)((next - now) % RMD_NS_PER_S);
		if (ppoll(&p, 1, &ts, NULL) > 0 && (p.revents & POLLOUT))
			wire_flush(s);
	}
	s->st.unsent = n;
	if (held)
		tool_log(TOOL_LOG_WARNING,
			 "rmd-sim: %s: the line had not taken every reply %d ms after the stop",
			 s->name, (int)(FINISH_NS / RMD_NS_PER_MS));
}

/* ---- the loop -------------------------------------------------------------------------- */

/* The next thing due, on rmd-sim's clock (`wall` is now on it). */
static int64_t next_deadline(const struct sim *s, int64_t wall)
{
	const struct rmd_sim_pending *h = rmd_sim_node_head(&s->node);
	int64_t now = world(s, wall), t = s->next_tick_ns, e;

	if (world(s, s->next_house_ns) < t)
		t = world(s, s->next_house_ns);
	if (h) {
		e = h->ready_ns;
		if (s->retry_ns > e)
			e = s->retry_ns;
		if (e < t)
			t = e;
	}
	if (s->motors_ns < t)
		t = s->motors_ns;
	e = rmd_sim_node_faults_next_ns(&s->node, now);
	return (e < t ? e : t) + s->slip_ns;
}

static void arm(struct sim *s, int64_t t)
{
	struct itimerspec its;

	memset(&its, 0, sizeof(its));
	if (t < 1)
		t = 1; /* 0 would disarm it */
	its.it_value.tv_sec = (time_t)(t / RMD_NS_PER_S);
	its.it_value.tv_nsec = (long)(t % RMD_NS_PER_S);
	timerfd_settime(s->tfd, TFD_TIMER_ABSTIME, &its, NULL);
}

static void watch_out(struct sim *s, bool on)
{
	uint32_t ev = EPOLLIN | (on ? EPOLLOUT : 0);
	struct epoll_event e = { .events = ev, .data.u32 = 0 };

	if (ev == s->ep_events)
		return;
	if (epoll_ctl(s->epfd, EPOLL_CTL_MOD, s->fd, &e) == 0)
		s->ep_events = ev;
}

/* What is due at rmd-sim's clock `now`. */
static void process(struct sim *s, int64_t now)
{
	update_faults(s, world(s, now));
	run_motors(s, now);
	if (now >= s->next_house_ns) {
		check_interface(s);
		s->next_house_ns = now + HOUSEKEEPING_NS;
	}
	write_due(s, world(s, now));
}

static void summary_faults(const struct sim *s, char *buf, size_t size)
{
	size_t n = 0;

	buf[0] = '\0';
	for (int k = 0; k < RMD_SIM_FAULT_COUNT && n < size; k++) {
		const char *name = rmd_sim_fault_kind_name((enum rmd_sim_fault_kind)k);

		if (s->node.stats.faults[k])
			n += (size_t)snprintf(buf + n, size - n, "%s %s %" PRIu64,
					      n ? "," : "; faults:", name ? name : "?",
					      s->node.stats.faults[k]);
	}
}

static void log_startup(const struct sim *s)
{
	static char desc[RMD_MAX_MOTORS][256];
	const struct sim_config *c = s->cfg;
	const struct rmd_sim_motor *motors = s->node.motors;
	unsigned n = s->node.n_motors;
	uint32_t done = 0;

	if (!tool_log_enabled(TOOL_LOG_INFO))
		return;
	tool_log(TOOL_LOG_INFO, "rmd-sim: %s: %s, %u motor%s, seed %" PRIu64, s->name,
		 s->serial ? "RS485 line" : "SocketCAN", n, n == 1 ? "" : "s", c->seed);
	if (c->yaml_bus[0])
		tool_log(TOOL_LOG_INFO, "rmd-sim: %s: %s", s->name, c->yaml_bus);
	if (s->serial)
		tool_log(TOOL_LOG_INFO, "rmd-sim: %s: %u baud 8N1%s", s->name, c->baud,
			 c->local_echo ? ", local echo dropped" : "");
	/* One line per set of motors that are alike. */
	for (unsigned i = 0; i < n; i++) {
		const struct rmd_sim_motor_params *p = &motors[i].p;

		snprintf(desc[i], sizeof(desc[i]),
			 "%s %s (fw %u), inertia %g kg·m², kt %g N·m/A, gear %g, load %g N·m, "
			 "supply %g V, %sbrake, turnaround %g±%g µs",
			 rmd_proto_name(p->proto), p->model, p->version_date, p->inertia_kgm2,
			 p->kt_nm_a, p->gear_ratio, p->load_nm, p->supply_v,
			 p->has_brake ? "" : "no ", p->turnaround_ns / 1e3,
			 p->turnaround_jitter_ns / 1e3);
		/* the firmware's personality in effect (rmd/sim_personality.h) */
		if (p->personality.source == RMD_PERSONALITY_BUILTIN ||
		    p->personality.source == RMD_PERSONALITY_FILE) {
			size_t at = strlen(desc[i]);

			snprintf(desc[i] + at, sizeof(desc[i]) - at, ", personality %s%s",
				 p->personality.name,
				 p->personality.n_turnaround ? " (turnaround per command)" : "");
		}
	}
	for (unsigned i = 0; i < n; i++) {
		uint32_t same = 0;
		char list[128];

		if (done & (UINT32_C(1) << i))
			continue;
		for (unsigned j = i; j < n; j++) {
			if (!strcmp(desc[i], desc[j])) {
				same |= UINT32_C(1) << (motors[j].p.id - 1);
				done |= UINT32_C(1) << j;
			}
		}
		sim_format_motors(same, list, sizeof(list));
		tool_log(TOOL_LOG_INFO, "rmd-sim: motor%s %s: %s", (same & (same - 1)) ? "s" : "",
			 list, desc[i]);
	}
	for (unsigned i = 0; i < n; i++)
		if (s->serial && !rmd_dialect_is_firmware(motors[i].d))
			tool_log(TOOL_LOG_INFO,
				 "rmd-sim: motor %u: MIT frames have no RS485 form; it "
				 "answers V3 commands",
				 motors[i].p.id);
	for (unsigned i = 0; i < c->n_faults; i++)
		tool_log(TOOL_LOG_INFO, "rmd-sim: fault %u: %s", i + 1, c->fault_text[i]);
}

static void log_summary(const struct sim *s, int64_t now)
{
	const struct rmd_bus_stats *bs = rmd_bus_stats(&s->bus);
	/* Serial: the transport's rx_errors are the runs of line noise, counted in bytes. */
	uint64_t rx_errors = s->st.rx_errors + (s->serial ? 0 : bs->rx_errors);
	char faults[512], unsent[80] = "", behind[192] = "";

	summary_faults(s, faults, sizeof(faults));
	if (s->st.behind)
		snprintf(behind, sizeof(behind),
			 "; physics behind real time %" PRIu64 " time%s (the worst %.1f ms)",
			 s->st.behind, s->st.behind == 1 ? "" : "s",
			 (double)s->st.behind_max_ns / 1e6);
	if (s->slip_ns)
		snprintf(behind + strlen(behind), sizeof(behind) - strlen(behind),
			 "; the world %.1f ms behind real time at the end (it fell behind %" PRIu64
			 " time%s)",
			 (double)s->slip_ns / 1e6, s->st.slips, s->st.slips == 1 ? "" : "s");
	if (s->st.unsent)
		snprintf(unsent, sizeof(unsent), "; %" PRIu64 " frame%s not sent before the stop",
			 s->st.unsent, s->st.unsent == 1 ? "" : "s");
	tool_log(s->status == SIM_EXIT_OK ? TOOL_LOG_INFO : TOOL_LOG_ERR,
		 "rmd-sim: %s: stopped (%s) after %.3f s: frames in %" PRIu64 " (answered %" PRIu64
		 "), out %" PRIu64 "; tx retries %" PRIu64 ", tx errors %" PRIu64
		 ", queue overflows %" PRIu64 ", rx errors %" PRIu64 ", line noise %" PRIu64
		 " bytes, echoes %" PRIu64 ", lost while absent %" PRIu64
		 ", without RS485 form %" PRIu64 "%s%s%s",
		 s->name, s->why ? s->why : "?", (double)(now - s->t0) / 1e9, s->st.rx_frames,
		 s->st.rx_taken, s->st.tx_frames, s->st.tx_busy, s->st.tx_errors,
		 s->node.stats.dropped, rx_errors, bs->rx_noise_bytes, bs->echoes,
		 s->node.stats.absent_lost, s->st.unmappable, faults, unsent, behind);
}

static void handle_signal(struct sim *s)
{
	struct signalfd_siginfo si;

	while (read(s->sfd, &si, sizeof(si)) == (ssize_t)sizeof(si)) {
		if (si.ssi_signo == SIGINT)
			stop(s, SIM_EXIT_OK, "SIGINT");
		else if (si.ssi_signo == SIGTERM)
			stop(s, SIM_EXIT_OK, "SIGTERM");
	}
}

static int add_fd(struct sim *s, int fd, uint32_t events, uint32_t tag)
{
	struct epoll_event e = { .events = events, .data.u32 = tag };

	return epoll_ctl(s->epfd, EPOLL_CTL_ADD, fd, &e);
}

enum { TAG_WIRE = 0, TAG_TIMER, TAG_SIGNAL };

int sim_run(const struct sim_config *c)
{
	static struct sim sim;
	struct sim *s = &sim;
	sigset_t mask;
	uint64_t rng;
	int r;

	memset(s, 0, sizeof(*s));
	s->cfg = c;
	s->name = c->device;
	s->serial = c->wire == SIM_WIRE_SERIAL;
	s->fd = s->epfd = s->tfd = s->sfd = -1;
	rng = c->seed * UINT64_C(0x9E3779B97F4A7C15) + UINT64_C(0x2545F4914F6CDD1D);
	for (unsigned k = 0; k < c->n_faults; k++) {
		if (rmd_sim_fault_check(&c->faults[k]) < 0) {
			tool_log(TOOL_LOG_ERR, "rmd-sim: the fault table does not hold together");
			return SIM_EXIT_USAGE;
		}
	}

	/* the physics first: a model that does not load leaves the wire alone */
	if (c->physics.n_joints) {
		char err[1024];

		if (rmd_sim_body_load(&s->body, &c->physics, err, sizeof(err)) < 0) {
			tool_log(TOOL_LOG_ERR, "rmd-sim: %s", err);
			return SIM_EXIT_USAGE;
		}
	}

	/* Replies are due within a turnaround: keep the kernel's timer slack at 1 µs. */
	(void)prctl(PR_SET_TIMERSLACK, 1000UL, 0, 0, 0);
	signal(SIGPIPE, SIG_IGN);
	sigemptyset(&mask);
	sigaddset(&mask, SIGINT);
	sigaddset(&mask, SIGTERM);
	if (sigprocmask(SIG_BLOCK, &mask, NULL) < 0) {
		tool_log(TOOL_LOG_ERR, "rmd-sim: sigprocmask: %s", strerror(errno));
		return SIM_EXIT_RUN;
	}
	s->sfd = signalfd(-1, &mask, SFD_NONBLOCK | SFD_CLOEXEC);
	s->tfd = timerfd_create(CLOCK_MONOTONIC, TFD_NONBLOCK | TFD_CLOEXEC);
	s->epfd = epoll_create1(EPOLL_CLOEXEC);
	if (s->sfd < 0 || s->tfd < 0 || s->epfd < 0) {
		tool_log(TOOL_LOG_ERR, "rmd-sim: signalfd/timerfd/epoll: %s", strerror(errno));
		r = SIM_EXIT_RUN;
		goto err_close_fds;
	}
	if ((s->serial ? serial_open(s) : can_open(s)) < 0) {
		r = SIM_EXIT_RUN;
		goto err_close_fds;
	}
	s->ep_events = EPOLLIN;
	if (add_fd(s, s->fd, EPOLLIN, TAG_WIRE) < 0 || add_fd(s, s->tfd, EPOLLIN, TAG_TIMER) < 0 ||
	    add_fd(s, s->sfd, EPOLLIN, TAG_SIGNAL) < 0) {
		tool_log(TOOL_LOG_ERR, "rmd-sim: epoll_ctl: %s", strerror(errno));
		r = SIM_EXIT_RUN;
		goto err_close_wire;
	}

	s->t0 = rmd_now_ns();
	rmd_sim_node_init(&s->node, s->q, TXQ, rng ? rng : 1, s->t0, RMD_SIM_NODE_HOST_ADAPTER);
	for (unsigned id = 1; id <= RMD_MAX_MOTORS; id++)
		if (c->motors & (UINT32_C(1) << (id - 1)))
			rmd_sim_node_add(&s->node, &c->params[id - 1], s->t0);
	for (unsigned id = 1; s->body && id <= RMD_MAX_MOTORS; id++)
		if (c->motors & (UINT32_C(1) << (id - 1)))
			(void)rmd_sim_body_attach(s->body, id - 1,
						  rmd_sim_node_motor(&s->node, id));
	if (s->body) {
		char what[512];

		rmd_sim_body_describe(s->body, what, sizeof(what));
		tool_log(TOOL_LOG_INFO, "rmd-sim: physics: %s", what);
	}
	rmd_sim_node_set_faults(&s->node, c->faults, c->n_faults, s->t0);
	s->motors_ns = INT64_MAX;
	s->world_ns = s->step_end_ns = s->t0; /* the motors' time from rmd_sim_node_add() */
	s->next_tick_ns = s->t0 + TICK_NS;
	/* a CAN interface's state is looked at; a line's is its hang-up */
	s->next_house_ns = s->serial ? INT64_MAX : s->t0 + HOUSEKEEPING_NS;
	log_startup(s);
	tool_log(TOOL_LOG_INFO, "rmd-sim: %s: ready", s->name);

	while (!s->stop) {
		struct epoll_event ev[4];
		int64_t now = rmd_now_ns();
		int n;

		process(s, now);
		if (s->stop)
			break;
		/* Replies the tty refused wait in the transport until it is writable. */
		watch_out(s, rmd_bus_next_due_ns(&s->bus) != INT64_MAX);
		arm(s, next_deadline(s, now));
		n = epoll_wait(s->epfd, ev, 4, -1);
		if (n < 0) {
			if (errno == EINTR)
				continue;
			tool_log(TOOL_LOG_ERR, "rmd-sim: epoll_wait: %s", strerror(errno));
			stop(s, SIM_EXIT_RUN, "epoll_wait failed");
			break;
		}
		for (int i = 0; i < n; i++) {
			uint32_t e = ev[i].events;

			switch (ev[i].data.u32) {
			case TAG_SIGNAL:
				handle_signal(s);
				break;
			case TAG_TIMER: {
				uint64_t ticks;

				while (read(s->tfd, &ticks, sizeof(ticks)) > 0)
					;
				break;
			}
			case TAG_WIRE:
				/* EPOLLOUT is asked for only while the transport holds replies */
				if (e & EPOLLOUT)
					wire_flush(s);
				/* a line hung up (a raw CAN socket has no hang-up) */
				if (e & (EPOLLIN | EPOLLHUP | EPOLLERR))
					wire_read(s, (e & EPOLLHUP) != 0);
				break;
			default:
				break;
			}
		}
	}
	if (s->status == SIM_EXIT_OK)
		finish(s);
	log_summary(s, rmd_now_ns());
	r = s->status;

err_close_wire:
	rmd_bus_close(&s->bus);
err_close_fds:
	if (s->epfd >= 0)
		close(s->epfd);
	if (s->tfd >= 0)
		close(s->tfd);
	if (s->sfd >= 0)
		close(s->sfd);
	rmd_sim_body_free(s->body);
	s->body = NULL;
	return r;
}
