/* SPDX-License-Identifier: MIT */
/*
 * Firmware dialects as data: one record per protocol generation (V2.0,
 * V3.x, V4.x), with everything the layers above the codec need to know about
 * it -- its command table, the CAN identifiers it uses, what it can do
 * (capability bits), its error flags, its bring-up probes and its MIT
 * scaling by firmware date and model.
 *
 * MIT is a way of driving V3 and V4 firmware (V3 §5, V4.2 §5), not a
 * firmware of its own: a record offers it (rmd_dialect_offers_mit()) and a
 * motor's `mode: mit` takes it (rmd/motor.h).  The `mit` key stays in the
 * list for the configurations and tools that name it: V3 firmware driven in
 * MIT, whose firmware is rmd_dialect_firmware() of it; the one question
 * that tells it from a firmware is rmd_dialect_is_firmware().
 *
 * This is the proto layer's answer to "what does this motor speak?".  A
 * motor record points at its dialect once, at init (rmd/motor.h); rt, bus,
 * sim and tools read the record's fields and capability bits and never
 * compare enum rmd_proto (tests/check-layers refuses such a comparison
 * outside src/proto/).  enum rmd_proto stays the dialect's key: an index
 * into the list, the value a config file names.
 *
 * How to add a dialect (docs/design.md "How to add a dialect"): its value
 * in enum rmd_proto (codec.h), its command table (src/proto/codec_<key>.c,
 * the rows with their words and ranges for tools), one row of the list in
 * src/proto/dialect.c, and the simulated motor's behaviour where it differs
 * (src/sim/, read through the same bits); tests/unit/test_new_dialect.c
 * adds one so and runs rmdctl encode and decode on it.
 *
 * Pure, const after the program is loaded, rt-safe.
 */
#ifndef RMD_DIALECT_H
#define RMD_DIALECT_H

#include <stdbool.h>
#include <stddef.h>
#include <stdint.h>

#include "rmd/codec.h"
#include "rmd/mit.h"

/* struct rmd_dialect.caps: what the motors of a dialect can do. */
enum {
	/* 0xB5 answers the model (V3 §2.32) */
	RMD_DIALECT_MODEL_B5 = 1u << 0,
	/* 0xB2 answers the firmware date (V3 §2.29) */
	RMD_DIALECT_VERSION_B2 = 1u << 1,
	/*
	 * 0xB3 sets the motor's own comm-loss protection (V3 §2.30); a motor
	 * whose protection tripped only echoes its next command and may send
	 * 0xF1 frames (docs/design.md).  V2 has none: nothing but its power
	 * stops a V2 motor when the host dies.
	 */
	RMD_DIALECT_COMM_LOSS_B3 = 1u << 2,
	/* 0x280 carries four torques, motors 1..4, one reply each (V2 §4.1) */
	RMD_DIALECT_BATCH_280 = 1u << 3,
	/* the command set also travels on RS485 (V3 §1.2); V2 is CAN only */
	RMD_DIALECT_RS485 = 1u << 4,
	/*
	 * control replies carry the rotor's single-turn encoder, not the
	 * output angle (V2 §3.32): the host unwraps it from a reference
	 */
	RMD_DIALECT_ENCODER_UNWRAP = 1u << 5,
	/*
	 * The `mit` key's record: V3 firmware driven in MIT, its control
	 * frames on 0x400 + ID, replies on 0x500 + ID (V3 §5); what tools
	 * decode MIT frames as.  A motor's MIT mode is its own (rmd/motor.h).
	 */
	RMD_DIALECT_MIT = 1u << 6,
	/* 0x20 function control (V3 §2.33): index 3 turns on 0x9A error reports */
	RMD_DIALECT_FUNC_CTRL = 1u << 7,
	/* 0x92's output angle is the fine position feedback (V3 §2.11, 0.01 deg) */
	RMD_DIALECT_FINE_ANGLE = 1u << 8,
	/*
	 * 0xA3 and 0xA5 track a position through the position loop (V3 §2.19,
	 * §2.21; removed in V3.7); in V2 they move (absolute, single turn)
	 */
	RMD_DIALECT_TRACK_A3_A5 = 1u << 9,
	/*
	 * the firmware takes MIT frames on 0x400 + ID (V3 §5, V4.2 §5): it
	 * offers MIT mode (rmd_dialect_offers_mit()), scaled by mit_scaling
	 */
	RMD_DIALECT_MIT_FRAMES = 1u << 10,
	/* 0x79 sets and reads the CAN ID on 0x300, both ways (V3 §4, V4.2 §4) */
	RMD_DIALECT_ID_300 = 1u << 11,
	/*
	 * 0xB6 makes the motor push a reply every n x 10 ms, and no longer
	 * answer that read (V4.2 §2.33); CAN only
	 */
	RMD_DIALECT_ACTIVE_REPLY = 1u << 12,
	/* 0x42 reads the acceleration of an index, as 0x43 writes it (V4.2 §2.4) */
	RMD_DIALECT_ACCEL_INDEX = 1u << 13,
	/* 0x20 index 4 keeps the multi-turn angle at power off (V3 §2.33.4, V4.2 §2.34.4) */
	RMD_DIALECT_MULTI_TURN_SAVE = 1u << 14,
	/* 0x20 indexes 6 and 7 set the position limits, in ROM (V4.2 §2.34.4) */
	RMD_DIALECT_ANGLE_LIMITS = 1u << 15,
};

/* How a motor's CAN ID is set (struct rmd_dialect.set_id). */
enum rmd_set_id {
	RMD_SET_ID_NONE = 0,
	RMD_SET_ID_79_OWN, /* 0x79 on the motor's own 0x140 + ID (V2 §3.52) */
	RMD_SET_ID_79_300, /* 0x79 on 0x300, to every motor (V3 §4) */
	/*
	 * 0x20 index 5 on the motor's own 0x140 + ID writes the new ID to ROM,
	 * 0x76 makes it effective (V4.2 §2.34.4).  X4-36 and X4-64 firmware of
	 * 2025 (0xB2 2025070202) no longer answer 0x79; they echo 0x20 from
	 * the new 0x240 + ID and take requests on the old one until the reset.
	 */
	RMD_SET_ID_FUNC_20,
};

/* How a motor's PID gains are read and written (struct rmd_dialect.pid). */
enum rmd_pid_layout {
	RMD_PID_NONE = 0,
	RMD_PID_V2_PER_GAIN, /* one command a gain and a place (V2 §3.1 .. §3.18) */
	RMD_PID_U8_SIX,	     /* six uint8 gains in one frame, 0x30/0x31/0x32 (V3 §2.1) */
	/*
	 * one float gain a frame, its index at data[1] (1, 2 current KP/KI;
	 * 4, 5 speed KP/KI; 7, 8, 9 position KP/KI/KD), 0x30/0x31/0x32
	 * (V4.2 §2.1 .. §2.3)
	 */
	RMD_PID_FLOAT_INDEXED,
};

/* What a PID request does (struct rmd_pid_slot.cmd, rmd_pid_requests()). */
enum rmd_pid_op {
	RMD_PID_READ = 0,
	RMD_PID_WRITE_RAM, /* lost at power off (V3 §2.2, V2 §3.7, V4.2 §2.2) */
	RMD_PID_WRITE_ROM, /* kept at power off (V3 §2.3, V2 §3.13, V4.2 §2.3) */
	RMD_PID_OPS
};

/*
 * One PID gain of a dialect's layout: the enum rmd_field it is known by
 * (its JSON and dump key, rmd_field_key()), the index that addresses it
 * where gains go one a frame by index (RMD_PID_FLOAT_INDEXED; 0 otherwise),
 * and the commands that read it, write it to RAM and to ROM (enum
 * rmd_pid_op).  Gains without an index that share a command travel in
 * one frame (V3 §2.1: six); each other gain in a frame of its own.
 */
struct rmd_pid_slot {
	uint8_t field;
	uint8_t index;
	uint8_t cmd[RMD_PID_OPS];
};

/* The most gains a layout has (V4.2 §2.1.4: seven). */
#define RMD_PID_SLOTS_MAX 7

/* One named error flag of a dialect's table. */
struct rmd_flag_name {
	uint16_t code;
	const char *name;
};

#define RMD_DIALECT_PROBES_MAX 4
#define RMD_DIALECT_REPORTS_MAX 8

/* What a row of a dialect's MIT scaling is (struct rmd_mit_scaling.kind). */
enum rmd_mit_row_kind {
	/*
	 * The manual's preset ranges (V3 §5.1, V4.2 §5.1), which firmware
	 * may be set up otherwise: an entry's `mit` ranges win over it.
	 */
	RMD_MIT_ROW_PRESET = 0,
	/*
	 * The firmware's own ranges for the motor's model: an entry's `mit`
	 * ranges must agree with them, but for the bounds of `disputed`
	 */
	RMD_MIT_ROW_FIXED,
};

/*
 * One row of a dialect's MIT scaling (struct rmd_dialect.mit_scaling):
 * the ranges MIT frames are scaled by on firmware dated `since` and later
 * (its 0xB2 answer, yyyymmddNN: rmd_mit_scaling_decide() reads an
 * eight-digit date as build 00), for motors whose 0xB5 model names the X
 * series `series` (X6: 6; 0: any model).  Where rows of one date name
 * series, a model of another series is unknown at that date.
 * docs/protocol-v4.md "MIT scaling" gives the table and its sources.
 */
struct rmd_mit_scaling {
	uint32_t since;
	uint8_t series;
	uint8_t kind; /* enum rmd_mit_row_kind */
	struct rmd_mit_ranges r;
	/*
	 * RMD_MIT_BOUND() bits whose value the sources contradict: an
	 * entry's value is taken for them, said in the bring-up report
	 */
	unsigned disputed;
	const char *source; /* "V4.4 X6", "V3 §5.1": for messages */
};

struct rmd_dialect {
	enum rmd_proto proto; /* its key; rmd_dialect(proto) returns this record */
	const char *key;      /* "v3": config files and command lines */
	const char *name;     /* "V3": the manuals' spelling, for messages */
	const char *manual;   /* the manual its table follows, for docs and messages */
	/*
	 * The dialect whose command table its 0x140 + ID frames use: itself,
	 * or V3 for MIT (V3 §5: an MIT motor answers the V3 command set).
	 */
	enum rmd_proto table;
	const struct rmd_cmd_spec *rows; /* the command table (rmd_cmd_table()), *n_rows rows */
	const size_t *n_rows;
	uint32_t caps; /* RMD_DIALECT_* */
	/* CAN identifiers (motor ID added to the bases) */
	uint16_t req_base;	 /* requests: 0x140 */
	uint16_t reply_base;	 /* replies: 0x240 (V3), or 0x140 shared with requests (V2) */
	uint16_t ctl_req_base;	 /* setpoint frames: 0x140, or 0x400 (MIT) */
	uint16_t ctl_reply_base; /* their replies: reply_base, or 0x500 (MIT) */
	enum rmd_set_id set_id;
	enum rmd_pid_layout pid;
	/* the gains of that layout, in order (V3 §2.1: six; V4.2 §2.1.4: seven by index) */
	const struct rmd_pid_slot *pid_slots;
	unsigned n_pid_slots;
	/* error flags, as 0x9A reports them */
	const struct rmd_flag_name *error_bits;
	size_t n_error_bits;
	/* whole error codes that are not bits (V2 §3.31 table 2), or none */
	const struct rmd_flag_name *error_codes;
	size_t n_error_codes;
	/*
	 * RMD_DIALECT_ACTIVE_REPLY: the commands whose replies 0xB6 can push
	 * (V4.2 §2.33.2), which bring-up turns off; or none
	 */
	uint8_t report_cmds[RMD_DIALECT_REPORTS_MAX];
	unsigned n_report_cmds;
	/* 0x70's run modes (V3 §2.23.3, V2 §3.45) */
	const struct rmd_flag_name *run_modes;
	size_t n_run_modes;
	/*
	 * Bring-up's probes, in order: the first tells whether the motor is
	 * there; status 0x9A is always among them.
	 */
	uint8_t probe[RMD_DIALECT_PROBES_MAX];
	unsigned n_probes;
	/*
	 * A 0xB2 firmware version of this generation seen in the field, which
	 * the simulator reports unless told another; 0: the dialect has no 0xB2.
	 */
	uint32_t example_version;
	/*
	 * RMD_DIALECT_MIT_FRAMES: the ranges its MIT frames are scaled by, by
	 * firmware date and model, oldest first (rmd_mit_scaling_decide())
	 */
	const struct rmd_mit_scaling *mit_scaling;
	unsigned n_mit_scaling;
};

/*
 * The dialect for a `protocol: auto` (docs/protocol-v4.md; no config reads
 * it yet), from a motor's 0xB2 answer (V3 §2.29:
 * yyyymmdd; newer firmware yyyymmddNN, rmd_version_date()).  A date on or
 * after 2024-05-28, V4.2's revision date (V4.2 §9: the float PID layout),
 * gives V4; a plausible earlier date V3 (V3.x, V4.0 and V4.1 firmware keep
 * V3.6's uint8 PID layout, the difference that matters to the tools); both
 * with *certain true.  No plausible date: V3, *certain false.  Never NULL.
 * rt-safe.
 */
const struct rmd_dialect *rmd_dialect_for_firmware(uint32_t version, bool *certain);

/*
 * Whether firmware version `version` certainly runs another firmware than
 * dialect d's (the `mit` key: V3's); *fw: the firmware it names.  The one
 * rule a motor's date is held to: bring-up and the loop refuse such a
 * motor (rmd/proc_ident.h), rmdctl says which --protocol it needs.
 * rt-safe.
 */
bool rmd_dialect_other_firmware(const struct rmd_dialect *d, uint32_t version,
				const struct rmd_dialect **fw);

/*
 * What firmware seen in the field does that no manual says (issue 32;
 * docs/protocol-v4.md "Firmware in the field"): one report each, by the
 * 0xB2 version the report names.  rmdd and the tools ask
 * rmd_firmware_quirks(); the simulator's personalities are the motors.
 */
enum rmd_quirk {
	/* 0x9A DATA[3] reads 1 while the motor runs commands, not "brake released" (V3 §2.12) */
	RMD_QUIRK_9A_BYTE3_RUNNING = 1u << 0,
	/* 0x79 answered with a 0xB2-shaped frame, the ID unchanged: 0x20 index 5 sets it */
	RMD_QUIRK_79_ANSWERS_B2 = 1u << 1,
	/* after 0x20 index 5 the new ID echoes and answers before 0x76, the old one too */
	RMD_QUIRK_NEW_ID_EARLY = 1u << 2,
	/* 0xA4 (position) ignored after an MIT frame until the motor is reset (0x76) */
	RMD_QUIRK_A4_AFTER_MIT = 1u << 3,
};

/*
 * The quirks (enum rmd_quirk) of firmware version `version` (0xB2, as
 * answered: yyyymmdd or yyyymmddNN).  A report names a model or two; a
 * quirk is taken for every model of that build, the side that refuses
 * rather than trusts.  0: none known.  rt-safe.
 */
unsigned rmd_firmware_quirks(uint32_t version);

/* The record of dialect `proto`, or NULL when there is none.  rt-safe. */
extern const struct rmd_dialect rmd_dialects[RMD_PROTO_COUNT]; /* read through rmd_dialect() */

static inline const struct rmd_dialect *rmd_dialect(enum rmd_proto proto)
{
	return (unsigned)proto < RMD_PROTO_COUNT ? &rmd_dialects[proto] : NULL;
}

/* Every dialect, in enum order (the list's length in *n). */
const struct rmd_dialect *rmd_dialect_list(size_t *n);

/* Whether d has every capability bit of `caps`.  rt-safe. */
static inline bool rmd_dialect_has(const struct rmd_dialect *d, uint32_t caps)
{
	return (d->caps & caps) == caps;
}

/*
 * Whether d is a firmware generation; false for the `mit` key, V3 firmware
 * driven in MIT: MIT is not a firmware of its own.  rt-safe.
 */
static inline bool rmd_dialect_is_firmware(const struct rmd_dialect *d)
{
	return d->table == d->proto;
}

/* The firmware d's motors run: d, or V3 for the `mit` key.  rt-safe. */
static inline const struct rmd_dialect *rmd_dialect_firmware(const struct rmd_dialect *d)
{
	return &rmd_dialects[d->table];
}

/* Whether d's firmware can be driven in MIT mode (V3 §5, V4.2 §5).  rt-safe. */
static inline bool rmd_dialect_offers_mit(const struct rmd_dialect *d)
{
	return rmd_dialect_has(d, RMD_DIALECT_MIT_FRAMES);
}

/*
 * Whether the MIT scaling of d's firmware depends on the firmware's date
 * and model (V4: V4.4 widens it); false: one preset (V3).  rt-safe.
 */
static inline bool rmd_dialect_mit_dated(const struct rmd_dialect *d)
{
	return rmd_dialect_firmware(d)->n_mit_scaling > 1;
}

/* Where a motor's MIT scaling comes from, or why it has none (struct rmd_mit_decision). */
enum rmd_mit_source {
	RMD_MIT_FROM_PRESET = 0, /* the manual's preset (V3 §5.1, V4.2 §5.1) */
	RMD_MIT_FROM_ENTRY,	 /* the entry's `mit` ranges (over a preset, or all ten given) */
	RMD_MIT_FROM_FIRMWARE,	 /* the firmware's own for its model (V4.4) */
	/* refused: */
	RMD_MIT_NO_MIT,	    /* the firmware offers no MIT mode (V2) */
	RMD_MIT_NO_DATE,    /* no plausible firmware date (0xB2 unanswered) */
	RMD_MIT_NO_MODEL,   /* firmware that scales by model, a model not in its table */
	RMD_MIT_CONTRADICTS /* a bound of the entry differs from the firmware's */
};

/* What rmd_mit_scaling_decide() decided. */
struct rmd_mit_decision {
	enum rmd_mit_source source;
	struct rmd_mit_ranges r; /* decided: what the frames are scaled by */
	/* the firmware's row that applies (FROM_PRESET, FROM_FIRMWARE, CONTRADICTS), else NULL */
	const struct rmd_mit_scaling *row;
	unsigned bound;	    /* CONTRADICTS: the first bound that differs (rmd_mit_bound()) */
	double entry_value; /* CONTRADICTS: the entry's value of it (the firmware's: row->r) */
	unsigned overrides; /* FROM_FIRMWARE: the disputed bounds taken from the entry */
	unsigned missing;   /* NO_DATE, NO_MODEL: the bounds the entry does not give */
	unsigned series;    /* the X series the model names (0: none) */
};

/* Whether dec decided a scaling (else it refuses MIT: dec->source says why).  rt-safe. */
static inline bool rmd_mit_decided(const struct rmd_mit_decision *dec)
{
	return dec->source <= RMD_MIT_FROM_FIRMWARE;
}

/*
 * The MIT scaling of a motor of dialect d (its firmware: rmd_dialect_firmware())
 * with firmware version `version` (0xB2; 0 or implausible: unknown) and
 * model `model` (0xB5; "" or NULL: unknown), whose config entry's ranges
 * are `entry` with the bounds of `given` (RMD_MIT_BOUND() bits) named in
 * it: the firmware's row for that date and model (the newest `since` not
 * after the version; among its rows the model's series, else one for any
 * model).  A preset row takes the entry's named bounds over it; a fixed
 * row refuses a named bound that differs from it (relative 1e-4) unless
 * disputed, whose entry value is taken; with no row for the model, or no
 * date, the entry must name all ten bounds.  Pure, rt-safe.
 */
void rmd_mit_scaling_decide(const struct rmd_dialect *d, uint32_t version, const char *model,
			    const struct rmd_mit_ranges *entry, unsigned given,
			    struct rmd_mit_decision *out);

/* Whether d's requests and replies share one identifier (V2 §1).  rt-safe. */
static inline bool rmd_dialect_shared_ids(const struct rmd_dialect *d)
{
	return d->req_base == d->reply_base;
}

/* The identifier of a set-ID (0x79) frame when it rides on one of its own; 0 otherwise. */
static inline uint32_t rmd_dialect_set_id_can(const struct rmd_dialect *d)
{
	return rmd_dialect_has(d, RMD_DIALECT_ID_300) ? RMD_CAN_SET_ID : 0;
}

/*
 * ---- The requests of a motor's settings (src/proto/dialect_req.c) ----
 *
 * How a dialect's PID gains are read and written, and how a motor's CAN ID
 * is set, as requests built from its record: rmdctl sends them, the
 * simulated motor answers them; neither asks which layout a dialect has.
 * Pure and rt-safe.
 */

/* Gains of a dialect by slot (struct rmd_dialect.pid_slots): which, and their raw values. */
struct rmd_pid_set {
	uint32_t slots; /* bit k: pid_slots[k] */
	/* as the wire carries them: V3 uint8 units, V2 Q24, V4 binary32 bits */
	int64_t raw[RMD_PID_SLOTS_MAX];
};

/*
 * The field that carries gain k of d in a frame: the gain's own (V3 §2.1,
 * V2 §3.1), or RMD_FLD_GAIN beside its index (V4.2 §2.1).
 */
enum rmd_field rmd_pid_field(const struct rmd_dialect *d, unsigned k);

/*
 * Gain k's field as the answer to its read carries it (its scale, and
 * is_float for a binary32), or NULL when d's table lacks the row.
 */
const struct rmd_field_spec *rmd_pid_spec(const struct rmd_dialect *d, unsigned k);

/*
 * The requests of d that do `op` to the gains of set->slots, in slot
 * order, into reqs[] (RMD_PID_SLOTS_MAX of them): gains that share a frame
 * share a request (V3 §2.1: one 0x30 reads all six), each other gain has
 * its own (V2 §3.1: 0x30 .. 0x35; V4.2 §2.1: 0x30 by index).  A write
 * carries set->raw[k] of each gain it holds: a frame that holds gains
 * beyond set->slots (V3: all six) carries theirs from set->raw too.
 * Returns the count, or -EINVAL (op), -ENOTSUP (d has no PID commands).
 */
int rmd_pid_requests(const struct rmd_dialect *d, enum rmd_pid_op op, const struct rmd_pid_set *set,
		     struct rmd_msg *reqs);

/*
 * Whether msg, decoded from d's table, is one of d's PID requests or the
 * answer to one: then *op, the gains it names in *named (bits; a read
 * request: those it asks for; none for an index d does not list), and
 * those it carries, with their values, in *carried.
 */
bool rmd_pid_parse(const struct rmd_dialect *d, const struct rmd_msg *msg, enum rmd_pid_op *op,
		   uint32_t *named, struct rmd_pid_set *carried);

/*
 * A motor's answer to PID read req of d, with the gains of set that req
 * names: rep (its command and fields; those of gains set lacks are 0).
 */
void rmd_pid_answer(const struct rmd_dialect *d, const struct rmd_msg *req,
		    const struct rmd_pid_set *set, struct rmd_msg *rep);

/* How a motor is renumbered (rmd_set_id_request()). */
struct rmd_set_id_req {
	struct rmd_msg write; /* to the motor's ID now: 0x79 (V3 §4, V2 §3.52) or 0x20 index 5 */
	/* it rides on 0x300: every motor whose CAN-ID filter is off takes it (V3 §4) */
	bool every_motor;
	/* its echo may come from the new ID's reply identifier (firmware 2025070202) */
	bool echo_from_new;
	/* the ID holds after `reset` to the old ID (V4.2 §2.34.4: 0x76); else at once */
	bool then_reset;
	struct rmd_msg reset;
};

/*
 * The requests of d that give a motor the ID new_id (struct
 * rmd_dialect.set_id), into *out.  Returns 0, -EINVAL for an ID outside
 * 1..RMD_MAX_MOTORS, -ENOTSUP when d sets no ID.
 */
int rmd_set_id_request(const struct rmd_dialect *d, uint8_t new_id, struct rmd_set_id_req *out);

/* Whether req, decoded from d's table, is d's ID write; the ID it gives in *id (unchecked). */
bool rmd_set_id_parse(const struct rmd_dialect *d, const struct rmd_msg *req, int64_t *id);

/*
 * What 0x79 with the read flag answers for a motor of ID id (V3 §4.4
 * example 2: its reply identifier 0x240 + ID; V2 §3.52: the ID), or -1 when
 * d's firmware takes no 0x79 (it sets its ID by 0x20: docs/protocol-v4.md).
 */
int64_t rmd_set_id_read_answer(const struct rmd_dialect *d, uint8_t id);

/*
 * Whether the firmware of a motor that answers on identifier can_id (its
 * reply or control reply identifier in some dialect) takes a 0x280 frame
 * for a command of its own: a V2 motor with ID 1..4 its slot's torque (V2
 * §4.1), any other dialect's motor the frame's bytes as a command to
 * itself while its CAN-ID filter is off (V3 §3; 0x20 index 2, V3 §2.33.4).
 * *id: the ID the identifier names (0: none).  rt-safe.
 */
bool rmd_dialect_takes_280(uint32_t can_id, uint8_t *id);

#endif /* RMD_DIALECT_H */
