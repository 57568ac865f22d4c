/* SPDX-License-Identifier: MIT */
/*
 * The rt loop's state: struct rmd_loop, struct lmotor and struct lbus, and
 * the declarations the files of src/rt/ that make up the loop's behaviour
 * share (rmd/loop.h is the public face).  From the top down, each file
 * calls only those below it, except loop.c and rt_thread.c, which call
 * each other:
 *
 *   bringup.c      probing and arming the motors before start   non-rt
 *   rt_thread.c    the SCHED_FIFO thread and its set-up         rt-safe / non-rt
 *   loop.c         construction, the cycle, schedule, publishing,
 *                  getters, stopping the motors                 rt-safe / non-rt
 *   loop_tx.c      a cycle's frames, one send                   rt-safe
 *   loop_rx.c      requests in flight (booking, loop_commit()),
 *                  matching, deadlines                          rt-safe
 *   lifecycle.c    loop_enter(), commands, the host watchdog;
 *                  applies the procedures' outcomes             rt-safe
 *   loop_env.c     the clock, sleeps and waits, events (loop_env.h)  rt-safe
 *   this header    the state, and helpers that call nothing above it
 *
 * The exchanges with a motor's firmware are records of their own, pure,
 * which bring-up and the loop both drive (each file's header says how):
 * proc_ident.c (which dialect), proc_silence.c (pushed replies off),
 * proc_arm.c (0xB3), proc_settle.c (a position after a power cycle),
 * proc_owed.c (the stop frames owed an echo) and reboot.c (did it reboot).
 *
 * Nothing outside src/rt/ includes this header.
 */
#ifndef RMD_LOOP_STATE_H
#define RMD_LOOP_STATE_H

#include <pthread.h>
#include <stdatomic.h>
#include <stdbool.h>
#include <stdint.h>
#include <time.h>

#include "rmd/hist.h"
#include "rmd/incident.h"
#include "rmd/time.h"
#include "rmd/loop.h"
#include "rmd/motor.h"
#include "rmd/multiturn.h"
#include "rmd/proc_arm.h"
#include "rmd/proc_ident.h"
#include "rmd/proc_owed.h"
#include "rmd/proc_effect.h"
#include "rmd/proc_settle.h"
#include "rmd/proc_silence.h"
#include "rmd/reboot.h"

#define OUTSTANDING 8 /* requests in flight per motor */
#define GONE 32	      /* requests given up per motor, whose answers may still come */
#define ONESHOTS 4    /* one-shot frames waiting per motor */
#define RX_BATCH 64   /* frames per recv() call */
#define RX_ROUNDS 8   /* recv() calls per bus per drain: bounded work */
#define TX_MAX (2 * RMD_PLAN_MAX_SLOTS) /* frames of one bus in one cycle: 2 a slot */
#define EVENT_INTERVAL_NS RMD_NS_PER_S	/* repeated bus events: at most one a second */
#define COLLECT_GUARD_NS 50000		/* stop polling the buses this long before the tick */
#define COLLECT_MIN_STEP_NS 50000	/* shortest wait between two looks at the buses */
/*
 * The state waits for the cycle's replies until this long before the next
 * tick: no controller could answer a later one in time (docs/design.md).  What is not in
 * by then is published after the tick's receive (rmd_loop_tick()), as
 * without the wait.
 */
#define PUBLISH_LEAD_NS 50000
#define COLLECT_SIM_STEP_NS 20000 /* a bus without a descriptor (sim): looked at this often */
#define STOP_TRIES 50		  /* rmd_loop_stop_motors(): sends per bus ... */
#define STOP_STEP_NS 200000	  /* ... this far apart */
#define RETRY_STEP_NS 100000	  /* a send refused on a healthy bus: tried again this often ... */
#define RETRY_SHARE 2		  /* ... for at most a period / RETRY_SHARE after its tick */

/* What a frame of a cycle is, to book it once the bus took it. */
enum req_kind {
	REQ_CONTROL = 0, /* a setpoint, or a safe action's streamed frame */
	REQ_STATUS,	 /* a status read (0x9A, 0x9C); the kinds below are rare (loop_commit()) */
	REQ_ONESHOT,	 /* the head of the motor's one-shot queue */
	REQ_BATCH,	 /* V2 0x280: one request, every batched motor answers */
	REQ_OWED,	 /* an owed 0x80 or 0x78, sent until its echo comes */
	REQ_NO_REPLY,	 /* a frame nothing answers (0xB6 off): not awaited */
};

/* A request in flight (its bit in struct lmotor.os_used says it is). */
struct outstanding {
	bool echo_is_reply; /* the command's answer repeats it (0x80, 0xB3, ...) */
	/* the answer's identifier and command byte (or RMD_MOTOR_CMD_MIT): os_keyof() */
	uint64_t key;
	uint64_t seq;	 /* send order */
	int64_t sent_ns; /* missed at sent_ns + its bus's reply_ns (loop_check_deadlines()) */
	uint8_t data[RMD_FRAME_LEN]; /* the request, to tell an echo */
};

struct lmotor {
	struct rmd_motor m; /* the motor's one record: identity, bus, limits, ... */
	/*
	 * The motor's state: its entry of rmd_loop.snap, so that the
	 * snapshot is filled without a copy (loop_fill_snapshot()).
	 */
	struct rmd_motor_state *st;
	struct outstanding os[OUTSTANDING];
	uint8_t os_used; /* bit k: os[k] is in flight (OUTSTANDING <= 8) */
	/*
	 * Requests given up (missed, or a bring-up try retried), newest
	 * last, a ring: an answer that comes for one is late, not unexpected
	 * (loop_gone(), loop_rx.c).
	 */
	struct gone {
		uint64_t key; /* os_keyof() of its answer; 0: free */
		int64_t sent_ns;
	} gone[GONE];
	unsigned gone_next;
	uint64_t seq;
	/* the newest request answered or echoed: its seq + 1 (0: none) and when it went */
	uint64_t heard_seq;
	int64_t heard_sent_ns;
	/* the last request whose answer the cycle that sent it waits for: its seq + 1 (loop_awaited()) */
	uint64_t await_seq;
	int64_t rtt_est_ns;	/* the mean round trip of its answers, an eighth each */
	unsigned consecutive;	/* missed replies in a row */
	struct rmd_setpoint sp; /* in force while ENABLED */
	/* what its lifecycle keeps from one state to the next (lifecycle.c) */
	struct lm_life {
		bool need_edge;	   /* enable = 1 counts only after an enable = 0 */
		bool damp_stream;  /* SAFE with MIT damp: the damp frame in every control slot */
		uint8_t stop_from; /* enum rmd_lifecycle: the state STOPPING was entered from */
		int64_t next_probe_ns;	/* LOST, or missing at bring-up: its next probe */
		uint32_t disables_seen; /* rmd_command.disables[] of this motor, acted on */
		uint32_t homes_seen;	/* rmd_home.seq[] of this motor, acted on */
	} life;
	struct rmd_frame oneshot[ONESHOTS];
	unsigned n_oneshot;
	/*
	 * The replies it may push unasked, to turn off (rmd/proc_silence.h).
	 * Beside n_oneshot and owed: loop_tx.c add_control() asks them at once.
	 */
	bool v2_ask_angle; /* V2 without its 0x92 reference: the last read asked 0x92 */
	struct rmd_silence sil;
	/* the frames it owes an echo of (rmd/proc_owed.h) */
	struct rmd_owed owed;
	/*
	 * Its firmware (rmd/proc_ident.h): model and date as read, open while
	 * a motor missing at bring-up has not told its date, refused when it
	 * was left out for good (nothing it says brings it back).
	 */
	struct rmd_ident ident;
	bool replied;
	uint64_t last_reply_cycle;
	/* its comm-loss protection, 0xB3 (rmd/proc_arm.h; lifecycle.c applies it) */
	struct rmd_arm arm;
	/*
	 * Multi-turn position after a power cycle (rmd/proc_settle.h; the
	 * decision is st->pos_certain and st->pos_trust, the facts m.mt)
	 */
	struct rmd_settle settle;
	/* whether its position commands have an effect (rmd/proc_effect.h), at its status polls */
	struct rmd_effect effect;
	/*
	 * A short power cycle (rmd/reboot.h): after a missed reply, whether
	 * it rebooted; while pending, its control slot carries the read that
	 * tells (loop_tx.c), its answer is judged in loop_rx.c, a reboot
	 * applied by loop_rebooted().
	 */
	struct rmd_reboot rb;
	struct rmd_latency lat; /* every matched reply; under rmd_loop.stat_seq */
	/* rmd_loop_stop_motors(): a final frame of it the bus did not take, or that went unanswered */
	bool stop_unreached;
};

struct txmeta {
	uint8_t motor; /* config index; unused for REQ_BATCH */
	uint8_t kind;  /* enum req_kind */
};

struct lbus {
	struct rmd_bus *bus;
	const struct rmd_plan_bus *pb;
	const struct rmd_config_bus *cb;
	/* reply identifier -> config index + 1 (0: no motor) */
	uint8_t by_v3[RMD_MAX_MOTORS + 1];  /* 0x240 + ID: V3 and V4 motors (MIT mode too) */
	uint8_t by_v2[RMD_MAX_MOTORS + 1];  /* 0x140 + ID: V2 motors */
	uint8_t by_mit[RMD_MAX_MOTORS + 1]; /* 0x500 + ID */
	int64_t reply_ns;		    /* reply deadline after the send */
	struct rmd_bus_rx rx[RX_BATCH];
	struct rmd_frame tx[TX_MAX];
	struct txmeta meta[TX_MAX];
	unsigned ntx;
	unsigned batch_rr; /* round robin of the 0x280 slot's own frames (loop_tx.c batch_own()) */
	/*
	 * A motor the configuration does not list answered on an identifier
	 * whose firmware takes the 0x280 frame for a command of its own
	 * (rmd_dialect_takes_280()), and the bus's entry does not say such
	 * motors have their CAN-ID filter on: the frame never goes out again
	 * (loop_tx.c batch_allowed()).  stray_id: the identifier it answered on.
	 */
	bool stray;
	uint32_t stray_id;
	uint8_t state_seen;
	/*
	 * Frames the bus took that may not have left yet: those taken since
	 * the last drain that received a frame, and the cycle before it
	 * (tx_last: the last send's); what a flush drops, or what stays
	 * queued when it cannot (loop_tx.c "No acknowledgement").
	 */
	unsigned tx_unheard, tx_last;
	/*
	 * A send of the cycle refused (ENOBUFS/EAGAIN) by a bus that carries
	 * frames (issue 32 point 8): its frames from tx_off on are sent again
	 * until retry_until_ns (loop_tx.c loop_retry_sends(); bit b of
	 * rmd_loop.retry_buses); heard_ns: the last drain that received a
	 * frame; tx_retried: frames a retry got onto the bus (health:
	 * rmd_bus_stats.tx_retried).
	 */
	unsigned tx_off;
	int64_t retry_until_ns, heard_ns;
	uint64_t tx_retried;
	uint64_t rx_early;     /* replies stamped before their request's send (rmd_bus_stats) */
	bool unacked;	       /* a no-acknowledgement episode is open (loop_tx.c) */
	uint32_t unacked_lost; /* ... and its motors LOST in it, bit k: pb->motors[k] */
	bool failing;
	int64_t ev_send_ns, ev_unexpected_ns, ev_late_ns;
	bool ev_send_any, ev_unexpected_any, ev_late_any;
	/* load over the last health window */
	uint64_t frames_t0;
	int64_t load_t0;
	double load;
	uint32_t unexpected_ids; /* bring-up: ids that answered but are not configured */
	uint32_t stray_ids;	 /* bring-up: of those, the ones a 0x280 frame would command */
	/* bring-up's scan: ids asked (0x9A) that did not answer in time, bit id - 1, and when */
	uint32_t scan_gone_ids;
	int64_t scan_sent_ns;
	/* bring-up: round trips of requests answered at their first try (struct rmd_bringup_bus) */
	unsigned rtt_n;
	int64_t rtt_min_ns, rtt_max_ns;
};

struct rmd_loop {
	struct rmd_loop_opts o;
	const struct rmd_config *cfg;
	const struct rmd_plan *plan;
	unsigned n_buses, n_motors;
	int64_t period_ns;
	struct lbus bus[RMD_MAX_BUSES];
	struct lmotor mot[RMD_MAX_MOTORS];

	/* schedule */
	bool started;
	bool stopping; /* rmd_loop_stop_motors() runs: SAFE's entry queues nothing */
	int64_t next_tick_ns;
	uint64_t cycle; /* index of the cycle running, from 0 */
	bool published; /* the running cycle's state is out (rmd_loop_publish()) */
	/* when the last reply the running cycle waits for is expected (loop_rx.c await_add()) */
	int64_t await_due_ns;
	unsigned retry_buses; /* bit b: bus b's refused frames are tried again (struct lbus.tx_off) */
	int64_t retry_next_ns; /* ... next at this time (loop_retry_sends()) */

	/* commands and the host watchdog */
	/*
	 * The newest command: the reader's slot of o.commands, which stays
	 * the loop's until its next rmd_latest_get() (no copy).  NULL: none yet.
	 */
	const struct rmd_command *cmd;
	int64_t inc_cmd_rx_ns; /* the newest command the incident recorder has */
	/* motor i, ENABLED: its last command's arrival + command_timeout_ms */
	int64_t cmd_due_ns[RMD_MAX_MOTORS];
	int64_t wd_due_ns; /* the earliest cmd_due_ns[] of the ENABLED motors, or later */
	/* bit i: motor i's 0xB3 round runs, or an enable waits for one (lifecycle.c) */
	uint32_t arm_busy;
	uint8_t wd; /* enum rmd_watchdog_state */
	int64_t trip_ns;
	uint32_t robot_stops_seen; /* the newest command's robot_stops, acted on */

	/* statistics */
	struct rmd_loop_stats stats;
	struct rmd_loop_counters cnt;
	/* wake-up lateness and reply latencies: written under stat_seq (stat_begin()) */
	atomic_uint stat_seq;
	struct loop_wake {
		uint64_t n;
		int64_t sum;
		uint64_t hist[RMD_HIST_BUCKETS];       /* rmd/hist.h buckets */
		uint64_t us[RMD_LOOP_WAKE_US_BUCKETS]; /* 1 us buckets */
		uint64_t over;			       /* at RMD_LOOP_WAKE_US_BUCKETS us or later */
	} wake;
	/*
	 * The same wake-ups over the last RMD_LOOP_WAKE_WIN_S seconds (health's
	 * wake_p99: a plot follows the load): one slot a second of CLOCK_MONOTONIC
	 * (uint16: at most RMD_CONFIG_RATE_MAX_HZ a second), and their sums.
	 * The rt thread's alone.
	 */
	struct loop_wake_win {
		int64_t slot_end_ns; /* the current slot's end; 0: no wake-up yet */
		unsigned cur;	     /* the current slot */
		uint64_t n;
		uint64_t hist[RMD_HIST_BUCKETS];
		uint64_t us[RMD_LOOP_WAKE_US_BUCKETS];
		struct loop_wake_slot {
			uint16_t n;
			uint16_t hist[RMD_HIST_BUCKETS];
			uint16_t us[RMD_LOOP_WAKE_US_BUCKETS];
		} slot[RMD_LOOP_WAKE_WIN_S];
	} wake_win;
	uint64_t ov_pending; /* ticks skipped, not yet reported */
	uint64_t ov_worst;   /* the most of them skipped at once */
	bool ov_any;
	int64_t ov_ev_ns;
	uint64_t next_health_cycle;
	unsigned health_every;
	unsigned state_every; /* lcm.state_every_n: the bridge is woken every this many cycles */

	/* the events' reader: woken at the end of a cycle that pushed events */
	int events_fd;	/* eventfd or -1 (rmd_loop_set_events_fd()) */
	bool ev_pushed; /* an event went into the ring since the last wake-up */

	/* work copies */
	struct rmd_snapshot snap;
	unsigned snap_slots;	  /* bit i: o.snapshots' slot i had one whole copy of snap */
	struct rmd_health health; /* filled every health_every cycles */
	bool health_fresh;	  /* filled, not yet in pub_health */

	/* for rmd_loop_get_*(): a sequence lock, written by the loop only */
	atomic_uint pub_seq;
	struct rmd_snapshot pub_snap;
	struct rmd_loop_stats pub_stats;
	struct rmd_loop_counters pub_cnt;
	bool pub_have_health; /* pub_health was written once */
	struct rmd_health pub_health;

	atomic_uint_fast64_t heartbeat;
	atomic_bool stop;
	pthread_t thread;
	bool running;
	bool locked;   /* mlockall done, or refused: */
	int mlock_err; /* -errno of the refusal, said when the thread starts */
	int qos_fd;    /* /dev/cpu_dma_latency held at 0 while the thread runs, or -1 */
};

/* Config index of lm.  rt-safe. */
static inline unsigned loop_idx(const struct rmd_loop *l, const struct lmotor *lm)
{
	return (unsigned)(lm - l->mot);
}

/*
 * The histograms other threads read (rmd_loop_get_wake_hist(),
 * rmd_loop_get_reply_latency()) change between stat_begin() and
 * stat_end(): a sequence lock, as the published copies.  rt-safe.
 */
static inline void stat_begin(struct rmd_loop *l)
{
	atomic_fetch_add_explicit(&l->stat_seq, 1, memory_order_relaxed);
	atomic_thread_fence(memory_order_release);
}

static inline void stat_end(struct rmd_loop *l)
{
	atomic_fetch_add_explicit(&l->stat_seq, 1, memory_order_release);
}

/* rt-safe. */
static inline enum rmd_safe_action loop_safe_action(const struct rmd_loop *l)
{
	return l->cfg->safety.safe_action;
}

/* The key of an answer: its identifier and command byte (or RMD_MOTOR_CMD_MIT).  rt-safe. */
static inline uint64_t loop_reply_key(uint32_t reply_id, uint16_t cmd)
{
	return (uint64_t)reply_id << 16 | cmd;
}

/*
 * A request of lm, sent at sent_ns, whose answer (loop_reply_key()) was
 * given up: if it still comes, it is late, not unexpected.  rt-safe.
 */
static inline void loop_gone(struct lmotor *lm, uint64_t key, int64_t sent_ns)
{
	struct gone *g = &lm->gone[lm->gone_next++ % GONE];

	g->key = key;
	g->sent_ns = sent_ns;
}

/*
 * loop_tx.c: the frame that turns lm's pushed reply report_cmds[k] off
 * (0xB6, V4.2 §2.33).  0 or rmd_encode()'s error.  rt-safe.
 */
int loop_report_off(const struct lmotor *lm, unsigned k, struct rmd_frame *f);

/* lifecycle.c: a position received while the settle decides the motor's (rmd/proc_settle.h).  rt-safe. */
__attribute__((cold)) void loop_pos_settle(struct rmd_loop *l, struct lmotor *lm, int64_t now);

/*
 * The read that tells whether lm rebooted (rmd/reboot.h): 0xB1, its
 * runtime, where its table has it; else V2's 0x92 angle, held against the
 * count of its encoder; 0: none.  rt-safe.
 */
static inline uint8_t loop_reboot_cmd(const struct lmotor *lm)
{
	if (rmd_motor_row(&lm->m, RMD_REBOOT_CMD_RUNTIME))
		return RMD_REBOOT_CMD_RUNTIME;
	if ((lm->m.caps & RMD_DIALECT_ENCODER_UNWRAP) &&
	    rmd_motor_row(&lm->m, RMD_MOTOR_CMD_FINE_POS))
		return RMD_MOTOR_CMD_FINE_POS;
	return 0;
}

/*
 * lifecycle.c: a setpoint in `mode`, which lm's firmware does not run now
 * (rmd_motor_runs()), refused -- the motor would hold its last output
 * while rmdd reported the target asked: an ENABLED motor gets the safe
 * action (SAFE) and waits for an enable = 0; reported once until it is
 * reset (RMD_EV_FW_REFUSED).  Returns RMD_IGN_FIRMWARE.  Cold.  rt-safe.
 */
__attribute__((cold, noinline)) int loop_fw_refuse(struct rmd_loop *l, struct lmotor *lm,
						   enum rmd_mode mode, int64_t now);

/*
 * lifecycle.c: lm rebooted (rmd/reboot.h): lost and back at once, its
 * requests in flight given up (loop_rx.c).  how: enum rmd_reboot_report,
 * what: its event's b.  rt-safe.
 */
void loop_rebooted(struct rmd_loop *l, struct lmotor *lm, unsigned how, int64_t what, int64_t now);

/* lifecycle.c: the homing requests the bridge handed over (rmd/state.h struct rmd_home).  rt-safe. */
void loop_take_homes(struct rmd_loop *l, int64_t now);

/* lifecycle.c.  rt-safe. */
void loop_enter(struct rmd_loop *l, struct lmotor *lm, enum rmd_lifecycle lc, int64_t now);

/*
 * The slot of lb's routing tables a received identifier falls in (which
 * holds its motor's index + 1, or 0), or NULL for an identifier no motor
 * answers on.  rt-safe.
 */
static inline uint8_t *lbus_slot(struct lbus *lb, uint32_t id)
{
	if (id > RMD_CAN_V3_REPLY_BASE && id <= RMD_CAN_V3_REPLY_BASE + RMD_MAX_MOTORS)
		return &lb->by_v3[id - RMD_CAN_V3_REPLY_BASE];
	if (id > RMD_CAN_REQ_BASE && id <= RMD_CAN_REQ_BASE + RMD_MAX_MOTORS)
		return &lb->by_v2[id - RMD_CAN_REQ_BASE];
	if (id > RMD_CAN_MIT_REPLY_BASE && id <= RMD_CAN_MIT_REPLY_BASE + RMD_MAX_MOTORS)
		return &lb->by_mit[id - RMD_CAN_MIT_REPLY_BASE];
	return NULL;
}

/* The motor a received identifier belongs to, or NULL.  rt-safe. */
static inline struct lmotor *loop_motor_of(struct rmd_loop *l, unsigned b, uint32_t id)
{
	const uint8_t *slot = lbus_slot(&l->bus[b], id);
	unsigned k = slot ? *slot : 0;

	return k ? &l->mot[k - 1] : NULL;
}

/* It answered its last request: it answered at all, and missed none since.  rt-safe. */
static inline bool loop_answers(const struct lmotor *lm)
{
	return lm->replied & !lm->consecutive;
}

/*
 * The cycle's state waits for its replies until PUBLISH_LEAD_NS before the
 * next tick (rt_thread.c between_ticks()).  rt-safe.
 */
static inline int64_t loop_publish_deadline(const struct rmd_loop *l)
{
	return l->next_tick_ns - PUBLISH_LEAD_NS;
}

/* loop.c.  rt-safe unless said. */
void loop_pub_write(struct rmd_loop *l);
void loop_fill_snapshot(struct rmd_loop *l, int64_t now);
void loop_fill_health(struct rmd_loop *l, int64_t now);
void loop_reached_tick(struct rmd_loop *l, int64_t now, bool served);
int64_t loop_reply_due(const struct rmd_loop *l, int64_t now, unsigned *owing);

/* rt_thread.c: end loop.keep_cpus_awake's request.  Non-rt. */
void loop_release_cpus(struct rmd_loop *l);

/* loop_rx.c.  rt-safe. */
void loop_commit(struct rmd_loop *l, struct lbus *lb, unsigned from, unsigned to, int64_t now);
void loop_unexpected(struct rmd_loop *l, unsigned b, const struct rmd_frame *f, int64_t now);
void loop_drain(struct rmd_loop *l, unsigned b, int64_t now);
void loop_check_deadlines(struct rmd_loop *l, int64_t now);
unsigned loop_awaited(const struct rmd_loop *l);

/* lifecycle.c.  rt-safe. */
void loop_frames_drop(struct lmotor *lm);
void loop_motor_lost(struct rmd_loop *l, struct lmotor *lm, int64_t now);
void loop_miss(struct rmd_loop *l, struct lmotor *lm, int64_t now);
void loop_note_errors(struct rmd_loop *l, struct lmotor *lm, uint16_t prev, int64_t now);
void loop_take_command(struct rmd_loop *l, int64_t now);
void loop_watchdog(struct rmd_loop *l, int64_t now);
void loop_comm_loss(struct rmd_loop *l, int64_t now);
bool loop_owed_frame(const struct lmotor *lm, struct rmd_frame *f);
void loop_owed_sent(struct rmd_loop *l, struct lmotor *lm, uint8_t cmd);
bool loop_owed_answer(struct rmd_loop *l, struct lmotor *lm, uint8_t cmd, uint64_t req_seq,
		      bool repeats, int64_t now);
void loop_owed_unpaid(struct rmd_loop *l, struct lmotor *lm, int64_t now);
void loop_cl_answer(struct rmd_loop *l, struct lmotor *lm, const uint8_t *req,
		    const struct rmd_frame *rep, int64_t now);
void loop_cl_outcome(struct rmd_loop *l, struct lmotor *lm, enum rmd_comm_loss cl, int64_t now);

/* loop_tx.c.  rt-safe. */
void loop_push_tx(struct lbus *lb, const struct rmd_frame *f, unsigned motor, enum req_kind kind);
bool loop_send_bus(struct rmd_loop *l, unsigned b, int64_t now);
/*
 * The frames refused on a healthy bus (rmd_loop.retry_buses) sent again;
 * what is still refused at its bus's retry_until_ns, or with give_up (the
 * next tick), fails as a refused send does.  rt-safe.
 */
void loop_retry_sends(struct rmd_loop *l, int64_t now, bool give_up);

#endif /* RMD_LOOP_STATE_H */
