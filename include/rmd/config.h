/* SPDX-License-Identifier: MIT */
/*
 * rmdd's configuration model (docs/design.md, layer tools): plain structs, their
 * defaults, and the names a config file spells.  The YAML file is read
 * by rmd_config_load() (rmd/config_yaml.h); the simulator's settings of a
 * sim bus are not here but in struct rmd_sim_setup (rmd/sim_setup.h),
 * which the loader fills beside this one.
 *
 * examples/rmdd.yaml documents every key.  Units are SI at the output
 * shaft (rad, rad/s, N·m, A), times in the unit their key names (_ms,
 * _us, _s).
 *
 * The model holds no pointers: strings are copied into fixed arrays and
 * the lists are fixed arrays sized by RMD_MAX_BUSES and RMD_MAX_MOTORS, so
 * the rt loop reads it without allocating, and it may be copied with
 * memcpy.  The bus budget (can every bus carry its motors at the loop rate)
 * is the planner's job (rmd/plan.h), not the loader's.
 */
#ifndef RMD_CONFIG_H
#define RMD_CONFIG_H

#include <stdbool.h>
#include <stddef.h>
#include <stdint.h>

#include "rmd/codec.h"
#include "rmd/dialect.h"
#include "rmd/frame.h"
#include "rmd/mit.h"
#include "rmd/mode.h"

#define RMD_CONFIG_NAME_LEN 32	  /* motor and bus names, NUL included */
#define RMD_CONFIG_IFNAME_LEN 16  /* IFNAMSIZ */
#define RMD_CONFIG_PATH_LEN 128	  /* RS485 device path */
#define RMD_CONFIG_URL_LEN 256	  /* LCM provider URL */
#define RMD_CONFIG_PREFIX_LEN 32  /* LCM channel prefix */
#define RMD_CONFIG_SOURCE_LEN 256 /* the file the config came from */
#define RMD_CONFIG_MAX_CPUS 64	  /* entries of loop.cpu_affinity */

#define RMD_CONFIG_RATE_MAX_HZ 2000 /* loop.rate_hz: 1..this */
/* STYLE.md / docs/design.md: SCHED_FIFO 1..49; IRQ threads sit at 50. */
#define RMD_CONFIG_PRIO_MAX 49
#define RMD_CONFIG_DIVISOR_MAX 1000 /* motors[].rate_divisor: 1..this */

/*
 * Lower bounds of physical quantities: below them a value means nothing
 * and its arithmetic (divisions, the MIT codes, the poll plan) overflows.
 */
#define RMD_CONFIG_MIN_GEAR_RATIO 0.01	    /* motors[].gear_ratio */
#define RMD_CONFIG_MIN_KT_NM_A 0.001	    /* motors[].torque_constant_nm_a */
#define RMD_CONFIG_MIN_LIMIT 0.001	    /* limits.velocity_rad_s, limits.torque_nm */
#define RMD_CONFIG_MIT_MIN_WIDTH 0.001	    /* mit: max - min of each range */
#define RMD_CONFIG_MIN_STATUS_POLL_HZ 0.001 /* status_poll_hz: 0 (off) or at least this */

#define RMD_CONFIG_DEFAULT_RATE_HZ 1000
#define RMD_CONFIG_DEFAULT_PRIORITY 40
/* lcm.rt_priority when the file does not set it: one below loop.rt_priority. */
#define RMD_CONFIG_LCM_PRIO_AUTO 0xffffu
#define RMD_CONFIG_DEFAULT_BITRATE 1000000
#define RMD_CONFIG_DEFAULT_BAUD 1000000
/* docs/design.md "Turnaround": a motor answers 0.5-0.8 ms after a request. */
#define RMD_CONFIG_DEFAULT_RS485_TURNAROUND_NS 800000
#define RMD_CONFIG_DEFAULT_COMM_LOSS_MS 100
#define RMD_CONFIG_DEFAULT_MISSED_LOST 10
#define RMD_CONFIG_DEFAULT_COMMAND_TIMEOUT_MS 100
/* safety.shutdown_action damp: damp this long before the brake. */
#define RMD_CONFIG_DEFAULT_SHUTDOWN_DAMP_MS 500
/* incidents: (docs/design.md "Incidents"). */
#define RMD_CONFIG_INCIDENT_DIR_LEN 256
#define RMD_CONFIG_DEFAULT_INCIDENT_BEFORE_S 3.0
#define RMD_CONFIG_DEFAULT_INCIDENT_AFTER_S 0.5
#define RMD_CONFIG_DEFAULT_INCIDENT_KEEP 20
#define RMD_CONFIG_DEFAULT_INCIDENT_OVERRUN_BURST 10
#define RMD_CONFIG_INCIDENT_MAX_WINDOW_S 60.0 /* before + after: memory the loop keeps */
#define RMD_CONFIG_DEFAULT_STATUS_POLL_HZ 10.0
#define RMD_CONFIG_DEFAULT_LCM_URL "udpm://239.255.76.67:7667?ttl=0"
#define RMD_CONFIG_DEFAULT_CHANNEL_PREFIX "RMD_"
#define RMD_CONFIG_DEFAULT_STALE_MS 100
#define RMD_CONFIG_DEFAULT_HEALTH_PERIOD_MS 100
/* robot: (docs/robot.md): instance names, peers, heartbeats. */
#define RMD_CONFIG_INSTANCE_LEN 32 /* robot.instance and each peer's name, NUL included */
#define RMD_CONFIG_MAX_PEERS 16	   /* robot.peers: entries, itself not among them */
#define RMD_CONFIG_DEFAULT_HEARTBEAT_MS 10
#define RMD_CONFIG_DEFAULT_PEER_TIMEOUT_MS 100
#define RMD_CONFIG_DEFAULT_MAX_CLOCK_OFFSET_MS 1000

enum rmd_bus_kind {
	RMD_BUS_KIND_SOCKETCAN = 0, /* "socketcan": a CAN netdev */
	RMD_BUS_KIND_RS485,	    /* "rs485": a serial line, V3 motors only */
	RMD_BUS_KIND_SIM,	    /* "sim": in-process simulated motors */
};

/* What rmdd does to a motor when its controller goes quiet or it is lost. */
enum rmd_safe_action {
	RMD_SAFE_STOP = 0, /* "stop": output off (0x80), the shaft turns freely */
	RMD_SAFE_HOLD,	   /* "hold": 0x81, decelerate and hold the position */
	RMD_SAFE_DAMP,	   /* "damp": zero speed with a torque limit (MIT: kp 0, kd > 0) */
	RMD_SAFE_BRAKE,	   /* "brake": output off and brake locked (0x80 + 0x78) */
};

/*
 * What rmdd sends when it exits (SIGTERM, SIGINT, the end of a run); the
 * motors' 0xB3 protection stays set.  docs/lcm.md "Shutdown" says what each
 * does to a standing robot.
 */
enum rmd_shutdown_action {
	RMD_SHUTDOWN_DEFAULT = 0, /* "default": brake when safe_action is brake, else stop */
	RMD_SHUTDOWN_STOP,	  /* "stop": 0x80 to every motor: output off */
	RMD_SHUTDOWN_HOLD,	  /* "hold": 0x81 to driven motors (0x80 to the others) */
	RMD_SHUTDOWN_DAMP,	  /* "damp": damp driven motors shutdown_damp_ms, then brake */
	RMD_SHUTDOWN_BRAKE,	  /* "brake": 0x80 + 0x78 to every motor */
};

/* What a daemon does when a peer of its robot is lost or reports a trip (robot.on_peer_lost). */
enum rmd_peer_lost {
	RMD_PEER_LOST_SAFE = 0, /* "safe": every driven motor gets the safe action */
	RMD_PEER_LOST_REPORT,	/* "report": said in the journal and health_t, nothing moves */
};

/* Whom a lost motor's safe action applies to. */
enum rmd_lost_action {
	RMD_LOST_MOTOR = 0, /* "motor": the lost motor only */
	RMD_LOST_ALL,	    /* "all": every motor */
};

/* What bring-up does when a configured motor does not answer the probe. */
enum rmd_on_missing {
	RMD_MISSING_REFUSE = 0, /* "refuse": exit with the report */
	RMD_MISSING_START,	/* "start": run the others, re-probe the missing */
};

/* Which shaft a protocol's angles and speeds belong to. */
enum rmd_units {
	RMD_UNITS_OUTPUT = 0, /* "output": V3 firmware; no conversion but direction */
	RMD_UNITS_ROTOR,      /* "rotor": divided by gear_ratio (some V2 firmware) */
};

struct rmd_config_loop {
	unsigned rate_hz;		    /* cycles per second, 1..RMD_CONFIG_RATE_MAX_HZ */
	unsigned rt_priority;		    /* SCHED_FIFO, 1..RMD_CONFIG_PRIO_MAX */
	uint16_t cpus[RMD_CONFIG_MAX_CPUS]; /* affinity of the rt thread; none: any */
	unsigned n_cpus;
	/*
	 * While the loop runs, ask the kernel for CPU wake-ups of 0 us (PM QoS,
	 * /dev/cpu_dma_latency): no CPU enters an idle state it cannot leave
	 * at once (docs/design.md "The cycle").  false: power management as is.
	 */
	bool keep_cpus_awake;
};

struct rmd_config_safety {
	uint32_t comm_loss_ms;	      /* 0xB3 (V3 §2.30, ROM) of every motor; 0: off */
	unsigned missed_replies_lost; /* consecutive missed replies: the motor is lost */
	uint32_t command_timeout_ms;  /* controller silent this long: safe_action */
	enum rmd_safe_action safe_action;
	enum rmd_lost_action lost_motor_action;
	enum rmd_shutdown_action shutdown_action; /* what rmdd sends when it exits */
	uint32_t shutdown_damp_ms;		  /* "damp": how long, then brake */
};

struct rmd_config_probe {
	/*
	 * A motor that does not answer the probe, or whose comm-loss
	 * protection (0xB3) could not be set at bring-up (unless it is off by
	 * config): refuse to start, or start and keep it from moving until it
	 * answers and is armed.
	 */
	enum rmd_on_missing on_missing;
	/*
	 * The longest bring-up (and the loop's re-arming through it) waits
	 * for one answer, ms: a USB-CAN adapter's 1 ms packets, a USB-RS485
	 * converter's 16 ms latency timer and firmware that writes ROM
	 * slowly all fit.  Once motors of a bus answered, requests to it wait
	 * a few of their measured round trips instead (rmd/bringup.h).
	 */
	unsigned reply_timeout_ms;
};

#define RMD_CONFIG_DEFAULT_PROBE_REPLY_TIMEOUT_MS 100

/*
 * The incident recorder: after a safety event, the frames, states,
 * commands and events of [event - seconds_before, event + seconds_after]
 * are written to a new directory under dir (docs/design.md "Incidents").
 */
struct rmd_config_incidents {
	bool enabled;
	/* "": $STATE_DIRECTORY/incidents (systemd), else $XDG_STATE_HOME/rmdd/incidents, ... */
	char dir[RMD_CONFIG_INCIDENT_DIR_LEN];
	double seconds_before;
	double seconds_after;
	unsigned keep;		/* recordings kept; the oldest are removed */
	unsigned overrun_burst; /* periods skipped in one overrun report that make an incident */
};

struct rmd_config_lcm {
	/*
	 * The LCM provider.  url_given: the file wrote it; else rmdd takes
	 * $LCM_DEFAULT_URL when set, as LCM's own tools do (docs/lcm.md).
	 */
	char url[RMD_CONFIG_URL_LEN];
	bool url_given;
	char channel_prefix[RMD_CONFIG_PREFIX_LEN];
	unsigned state_every_n;	   /* publish motor state every n cycles */
	uint32_t stale_ms;	   /* reject commands this much older than the newest; 0: off */
	uint32_t health_period_ms; /* publish health this often */
	/*
	 * SCHED_FIFO priority of the bridge thread and of LCM's receive
	 * thread, below loop.rt_priority; 0: normal priority;
	 * RMD_CONFIG_LCM_PRIO_AUTO: loop.rt_priority - 1 (docs/design.md).
	 */
	unsigned rt_priority;
};

/*
 * robot: (docs/robot.md): this daemon as one named part of a robot.  No
 * section (instance ""): a daemon alone, as before: no heartbeat, no peers.
 */
struct rmd_config_robot {
	char instance[RMD_CONFIG_INSTANCE_LEN]; /* [a-z0-9_], unique on the robot; "": none */
	char peers[RMD_CONFIG_MAX_PEERS][RMD_CONFIG_INSTANCE_LEN];
	unsigned n_peers;
	uint32_t heartbeat_ms;	  /* heartbeat_t period */
	uint32_t peer_timeout_ms; /* a peer silent this long is lost */
	enum rmd_peer_lost on_peer_lost;
	/* a peer whose clock differs by more than this is tripped on: it cannot be compared */
	uint32_t max_clock_offset_ms;
};

struct rmd_config_bus {
	char name[RMD_CONFIG_NAME_LEN]; /* [a-z0-9_], unique; for messages and LCM */
	enum rmd_bus_kind kind;
	char interface[RMD_CONFIG_IFNAME_LEN]; /* socketcan: netdev name (default: name) */
	char device[RMD_CONFIG_PATH_LEN];      /* rs485: serial device */
	uint32_t bitrate;		       /* socketcan, sim: bit/s */
	uint32_t baud;			       /* rs485: bit/s (V3 §1.2.1) */
	int64_t turnaround_ns; /* rs485: request end to reply start, budgeted per request */
	/*
	 * socketcan, sim: the motors on the bus that the file does not list
	 * (spares, entries left out) have their CAN-ID filter on (0x20 index 2
	 * = 1, V3 §2.33.4), so a V2 0x280 frame does not reach them; without
	 * it a bus whose V2 motors share one 0x280 frame does not send it
	 * while such a motor answers (issue 33 point 2, docs/design.md).
	 */
	bool can_id_filter;
	unsigned line; /* of the entry in the file, for messages */
	/*
	 * socketcan, rs485: the file gives the bus or a motor on it a `sim:`
	 * section.  It is rmd-sim's, which simulates the bus's motors on the
	 * real wire (docs/rmd-sim.md); rmdd does not use it.
	 */
	bool sim_section;
};

struct rmd_config_limits {
	/* Output-shaft position window; omitted: none (-inf, +inf). */
	double position_min_rad, position_max_rad;
	double velocity_rad_s; /* |velocity| setpoint limit; omitted: none (+inf) */
	double torque_nm;      /* |torque| setpoint limit; omitted: none (+inf) */
};

/*
 * Where a motor's reported position comes from (motors[].feedback.position;
 * docs/feedback.md).
 */
enum rmd_feedback_pos {
	/* "control": the replies to its setpoints and status reads (V3: whole degrees) */
	RMD_FEEDBACK_CONTROL = 0,
	/*
	 * "multi_turn": 0x92 reads (V3 §2.11: output multi-turn angle, 0.01
	 * deg) planned between the setpoints; the position is the newest
	 * read's, with its receive time, and the control replies' angle is not
	 * used.  V3 and MIT motors (V2 control replies carry the encoder).
	 */
	RMD_FEEDBACK_MULTI_TURN,
};

struct rmd_config_feedback {
	enum rmd_feedback_pos position;
	double rate_hz; /* 0x92 reads per second; 0: the motor's command rate */
};

struct rmd_config_motor {
	char name[RMD_CONFIG_NAME_LEN]; /* [a-z0-9_], unique */
	unsigned bus;			/* index into rmd_config.buses[] */
	uint8_t id;			/* 1..32, unique per bus */
	/*
	 * Its firmware dialect (rmd/dialect.h).  With `protocol: auto`
	 * (proto_auto) this is V3 until bring-up decides from what the motor
	 * says (docs/protocol-v4.md "Which dialect a motor speaks").
	 */
	enum rmd_proto proto;
	bool proto_auto;
	enum rmd_mode mode;
	int direction;	   /* +1, or -1: the motor turns the other way */
	double gear_ratio; /* motor turns per output turn, > 0 */
	enum rmd_units units;
	double zero_offset_rad;	     /* output-shaft position that rmdd reports as 0 */
	double torque_constant_nm_a; /* output N·m per A of iq; 0: unknown (MIT only) */
	struct rmd_config_limits limits;
	/*
	 * MIT packing ranges: its `mit` keys over V3 §5.1's preset; which of
	 * them the entry names, RMD_MIT_BOUND() bits (rmd/mit.h).  Bring-up
	 * decides the scaling from them and the firmware (rmd/dialect.h
	 * rmd_mit_scaling_decide()).
	 */
	struct rmd_mit_ranges mit;
	unsigned mit_given;
	unsigned rate_divisor; /* commanded every n-th cycle, 1.. */
	double status_poll_hz; /* 0x9A polls per second; 0: none */
	/*
	 * This motor's 0xB3 time (V3 §2.30), ms; 0: its protection off, by
	 * choice; RMD_CONFIG_COMM_LOSS_INHERIT: safety.comm_loss_ms.  Read it
	 * with rmd_config_comm_loss_ms().
	 */
	int32_t comm_loss_ms;
	struct rmd_config_feedback feedback; /* where state_t.position comes from */
	/*
	 * Whether the reported position survives a power cycle
	 * (rmd/multiturn.h): the motor keeps its multi-turn count at
	 * power-off (set with 0x20 index 4, V3 §2.33.4, on firmware that has
	 * it); or the joint's travel, [travel_rad[0], travel_rad[1]] in the
	 * reported frame when n_travel is 2 (else its position limits).
	 */
	bool multi_turn_saved;
	/*
	 * Issue 20.13: after the brake release (0x77, V3 §2.26) rmdd sends
	 * this motor status reads only, no setpoint, for this long, so no
	 * torque works against a brake still opening; 0: no brake (setpoints
	 * from the next slot).  Users of braked RMD motors measured 50..150 ms.
	 */
	uint32_t brake_release_ms;
	double travel_rad[2];
	unsigned n_travel; /* 0: none, or 2 */
	unsigned line;	   /* of the entry in the file, for messages */
	/*
	 * Of limits.position_min_rad, limits.position_max_rad and travel_rad
	 * in the file, for rmdd --check-config's warnings; 0: not written.
	 */
	unsigned pos_min_line, pos_max_line, travel_line;
};

/*
 * Whether motor c is driven in MIT mode (V3 §5, V4.2 §5): `mode: mit`, or
 * the key `protocol: mit`, V3 firmware driven in MIT (rmd/dialect.h).
 * The one copy of the rule: the motor record, the buses' filters and
 * bring-up ask it.  rt-safe.
 */
static inline bool rmd_config_mit_mode(const struct rmd_config_motor *c)
{
	const struct rmd_dialect *d = rmd_dialect(c->proto);

	return c->mode == RMD_MODE_MIT || (d && !rmd_dialect_is_firmware(d));
}

/*
 * Motor c's travel band, rad in the reported frame: travel_rad when set,
 * else its position limits (+-INFINITY when it has none).  rt-safe.
 */
static inline void rmd_config_travel(const struct rmd_config_motor *c, double *lo, double *hi)
{
	if (c->n_travel == 2) {
		*lo = c->travel_rad[0];
		*hi = c->travel_rad[1];
	} else {
		*lo = c->limits.position_min_rad;
		*hi = c->limits.position_max_rad;
	}
}

#define RMD_CONFIG_COMM_LOSS_INHERIT (-1)

struct rmd_config {
	char source[RMD_CONFIG_SOURCE_LEN]; /* the file, or "(built-in sim)" */
	struct rmd_config_loop loop;
	struct rmd_config_safety safety;
	struct rmd_config_probe probe;
	struct rmd_config_lcm lcm;
	struct rmd_config_robot robot;
	struct rmd_config_incidents incidents;
	struct rmd_config_bus buses[RMD_MAX_BUSES];
	unsigned n_buses;
	struct rmd_config_motor motors[RMD_MAX_MOTORS];
	unsigned n_motors;
};

/* Motor i's 0xB3 time in ms (its own key, else safety.comm_loss_ms); 0: off.  rt-safe. */
static inline uint32_t rmd_config_comm_loss_ms(const struct rmd_config *cfg, unsigned i)
{
	int32_t ms = cfg->motors[i].comm_loss_ms;

	return ms >= 0 ? (uint32_t)ms : cfg->safety.comm_loss_ms;
}

/*
 * Whether a faulted motor gets its brake locked (0x78, V3 §2.27): it runs
 * no control command (V3 §2.17.1), so hold and damp, which ask for a joint
 * that stays put, can only be kept by the brake, and so does a config whose
 * shutdown action uses the brake; only a config that asks for a free shaft
 * everywhere (safe_action stop, shutdown_action without the brake) leaves
 * it as it was.  rt-safe.
 */
static inline bool rmd_config_fault_brakes(const struct rmd_config *cfg)
{
	return cfg->safety.safe_action != RMD_SAFE_STOP ||
	       cfg->safety.shutdown_action == RMD_SHUTDOWN_BRAKE ||
	       cfg->safety.shutdown_action == RMD_SHUTDOWN_DAMP;
}

/* Every default, no buses and no motors.  Non-rt. */
void rmd_config_defaults(struct rmd_config *cfg);

/* A bus's and a motor's defaults, as a config entry starts.  Non-rt. */
void rmd_config_bus_defaults(struct rmd_config_bus *b);
void rmd_config_motor_defaults(struct rmd_config_motor *m);

/* The index of the bus or motor called `name`, or -ENOENT.  rt-safe. */
int rmd_config_bus_find(const struct rmd_config *cfg, const char *name);

/*
 * The real wire of bus b, as rmd-sim answers on it: its SocketCAN interface
 * (*serial false) or its RS485 device (*serial true); NULL for a bus rmdd
 * simulates in-process (type sim).  rt-safe.
 */
const char *rmd_config_bus_wire(const struct rmd_config_bus *b, bool *serial);
int rmd_config_motor_find(const struct rmd_config *cfg, const char *name);

/* Names as the file spells them, indexed by their enum, NULL-terminated. */
/*
 * The `protocol` key's values: every dialect's key, then "auto"
 * (RMD_CONFIG_PROTO_AUTO, which the loader turns into proto_auto and a V3
 * provisional dialect).  NULL-terminated; filled before main().
 */
#define RMD_CONFIG_PROTO_AUTO ((enum rmd_proto)RMD_PROTO_COUNT)
extern const char *rmd_config_proto_keys[RMD_PROTO_COUNT + 2];

extern const char *const rmd_bus_kind_names[];
extern const char *const rmd_mode_names[];
extern const char *const rmd_units_names[];
extern const char *const rmd_safe_action_names[];
extern const char *const rmd_lost_action_names[];
extern const char *const rmd_shutdown_action_names[];
extern const char *const rmd_on_missing_names[];
extern const char *const rmd_feedback_pos_names[];
extern const char *const rmd_peer_lost_names[];

/*
 * Names as the file spells them ("socketcan", "torque", "damp", ...;
 * protocols: rmd_proto_key() in rmd/codec.h).  rt-safe.
 */
const char *rmd_bus_kind_name(enum rmd_bus_kind kind);
const char *rmd_mode_name(enum rmd_mode mode);
const char *rmd_safe_action_name(enum rmd_safe_action action);

/*
 * Configuration files (rmdd's YAML, rmd-sim's --config) are a few kB: a
 * file larger than this is refused before it is read.
 */
#define RMD_CONFIG_FILE_MAX (1024 * 1024)
#define RMD_CONFIG_FILE_MAX_TEXT "1 MiB"

/*
 * Read the configuration file `path` whole into a malloc'ed, NUL-terminated
 * *buf of *len bytes.  Refused, with why[] saying so: anything but a regular
 * file (opened non-blocking, so a FIFO cannot block), a file larger than
 * RMD_CONFIG_FILE_MAX, and a NUL byte in the text (*line is then its line;
 * else 0).  Returns 0, or -errno (-EISDIR, -EINVAL for a special file,
 * -EFBIG, -EILSEQ for a NUL, or open's and read's).  Non-rt.
 */
int rmd_config_file_read(const char *path, char **buf, size_t *len, unsigned *line, char *why,
			 size_t whylen);

#endif /* RMD_CONFIG_H */
