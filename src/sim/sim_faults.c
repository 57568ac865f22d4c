// SPDX-License-Identifier: MIT
/*
 * Injected faults (rmd/sim_faults.h): the one engine behind the in-process
 * wire and rmd-sim.  rt-safe: fixed arrays, loops bounded by the table.
 */
#include <ctype.h>
#include <errno.h>
#include <string.h>

#include "rmd/rng.h"
#include "rmd/sim_faults.h"

_Static_assert(RMD_SIM_MAX_FAULTS <= 32, "rmd_sim_faults_update() returns a 32-bit mask");

const char *const rmd_sim_fault_kind_names[RMD_SIM_FAULT_COUNT + 1] = {
	[RMD_SIM_FAULT_DROP] = "drop",
	[RMD_SIM_FAULT_DELAY] = "delay",
	[RMD_SIM_FAULT_BAD_DLC] = "bad_dlc",
	[RMD_SIM_FAULT_GARBAGE] = "garbage",
	[RMD_SIM_FAULT_WRONG_ID] = "wrong_id",
	[RMD_SIM_FAULT_DISAPPEAR] = "disappear",
	[RMD_SIM_FAULT_ERROR_FLAG] = "error_flag",
	[RMD_SIM_FAULT_BUS_OFF] = "bus_off",
	[RMD_SIM_FAULT_FLOOD] = "flood",
	[RMD_SIM_FAULT_BUS_POWER] = "bus_power",
	[RMD_SIM_FAULT_COUNT] = NULL,
};

const char *rmd_sim_fault_kind_name(enum rmd_sim_fault_kind kind)
{
	return (unsigned)kind < RMD_SIM_FAULT_COUNT ? rmd_sim_fault_kind_names[kind] : NULL;
}

int rmd_sim_fault_kind_from_name(const char *name)
{
	char buf[16];
	size_t n;

	if (!name || (n = strlen(name)) >= sizeof(buf))
		return -EINVAL;
	/* rmd-sim's old spellings: any case, '-' for '_', "error" for error_flag */
	for (size_t i = 0; i <= n; i++)
		buf[i] = name[i] == '-' ? '_' : (char)tolower((unsigned char)name[i]);
	if (!strcmp(buf, "error"))
		return RMD_SIM_FAULT_ERROR_FLAG;
	for (int k = 0; k < RMD_SIM_FAULT_COUNT; k++)
		if (!strcmp(buf, rmd_sim_fault_kind_names[k]))
			return k;
	return -EINVAL;
}

#define FAULT_MAX_NS INT64_C(10000000000) /* a delay or a flood's interval: 10 s at most */

static const struct rmd_sim_fault_rule rules[RMD_SIM_FAULT_COUNT] = {
	[RMD_SIM_FAULT_DROP] = { 0 },
	[RMD_SIM_FAULT_DELAY] = { .param_lo = 0,
				  .param_hi = FAULT_MAX_NS,
				  .param_what = "the delay in ns" },
	[RMD_SIM_FAULT_BAD_DLC] = { .param_lo = 0,
				    .param_hi = RMD_FRAME_LEN - 1,
				    .param_what = "the DLC" },
	[RMD_SIM_FAULT_GARBAGE] = { 0 },
	[RMD_SIM_FAULT_WRONG_ID] = { .param_lo = 1,
				     .param_hi = RMD_MAX_MOTORS,
				     .param_what = "the motor id whose identifier is used" },
	[RMD_SIM_FAULT_DISAPPEAR] = { .window = true,
				      .param_lo = 0,
				      .param_hi = 1,
				      .param_what = "1 when the motor loses power" },
	[RMD_SIM_FAULT_ERROR_FLAG] = { .window = true,
				       .param_lo = 1,
				       .param_hi = 0xFFFF,
				       .param_what = "the error bits (V3 §2.12)" },
	[RMD_SIM_FAULT_BUS_OFF] = { .window = true, .bus_wide = true },
	[RMD_SIM_FAULT_FLOOD] = { .window = true,
				  .bus_wide = true,
				  .param_lo = 1,
				  .param_hi = FAULT_MAX_NS,
				  .param_what = "the interval in ns" },
	[RMD_SIM_FAULT_BUS_POWER] = { .window = true,
				      .bus_wide = true,
				      .param_lo = 0,
				      .param_hi = 0,
				      .param_what = "bus_power takes none" },
};

const struct rmd_sim_fault_rule *rmd_sim_fault_rule(enum rmd_sim_fault_kind kind)
{
	return (unsigned)kind < RMD_SIM_FAULT_COUNT ? &rules[kind] : NULL;
}

bool rmd_sim_fault_is_window(enum rmd_sim_fault_kind kind)
{
	const struct rmd_sim_fault_rule *r = rmd_sim_fault_rule(kind);

	return r && r->window;
}

int rmd_sim_fault_check(const struct rmd_sim_fault *f)
{
	const struct rmd_sim_fault_rule *r = rmd_sim_fault_rule(f->kind);

	if (!r || f->motor_id > RMD_MAX_MOTORS)
		return -EINVAL;
	if (f->end_ns != 0 && f->end_ns <= f->start_ns)
		return -EINVAL;
	if (!r->window && !(f->probability >= 0.0 && f->probability <= 1.0))
		return -EINVAL;
	if (r->bus_wide && f->motor_id != 0)
		return -EINVAL;
	if (r->param_what && (f->param < r->param_lo || f->param > r->param_hi))
		return -EINVAL;
	if (f->kind == RMD_SIM_FAULT_FLOOD && f->can_id > 0x7FF) /* an 11-bit identifier */
		return -EINVAL;
	return 0;
}

bool rmd_sim_fault_hits(const struct rmd_sim_fault *f, uint8_t motor_id)
{
	return f->motor_id == 0 || f->motor_id == motor_id;
}

static bool window_open(const struct rmd_sim_fault *f, int64_t t)
{
	return t >= f->start_ns && (f->end_ns == 0 || t < f->end_ns);
}

void rmd_sim_faults_init(struct rmd_sim_faults *fs)
{
	memset(fs, 0, sizeof(*fs));
	fs->last_ns = INT64_MAX; /* the first update scans */
}

/* The first start or end of a window after t; INT64_MAX: none. */
static int64_t next_edge(const struct rmd_sim_faults *fs, int64_t t)
{
	int64_t n = INT64_MAX;

	for (unsigned k = 0; k < fs->n; k++) {
		const struct rmd_sim_fault *f = &fs->f[k];

		if (!rmd_sim_fault_is_window(f->kind))
			continue;
		if (f->start_ns > t && f->start_ns < n)
			n = f->start_ns;
		if (f->end_ns > t && f->end_ns < n)
			n = f->end_ns;
	}
	return n;
}

/* The motors' and the bus's state from the open windows. */
static void refresh(struct rmd_sim_faults *fs)
{
	fs->bus_off = false;
	fs->bus_unpowered = false;
	fs->absent = fs->unpowered = 0;
	memset(fs->error_bits, 0, sizeof(fs->error_bits));
	for (unsigned k = 0; k < fs->n; k++) {
		const struct rmd_sim_fault *f = &fs->f[k];
		uint32_t hit = f->motor_id ? UINT32_C(1) << (f->motor_id - 1) : UINT32_MAX;

		if (!fs->open[k])
			continue;
		if (f->kind == RMD_SIM_FAULT_BUS_OFF) {
			fs->bus_off = true;
		} else if (f->kind == RMD_SIM_FAULT_BUS_POWER) {
			/* every motor is off the supply: absent and unpowered, as DISAPPEAR 1 */
			fs->bus_unpowered = true;
			fs->absent = fs->unpowered = UINT32_MAX;
		} else if (f->kind == RMD_SIM_FAULT_DISAPPEAR) {
			fs->absent |= hit;
			if (f->param == 1)
				fs->unpowered |= hit;
		} else if (f->kind == RMD_SIM_FAULT_ERROR_FLAG) {
			for (unsigned i = 0; i < RMD_MAX_MOTORS; i++)
				if (hit & (UINT32_C(1) << i))
					fs->error_bits[i] |= (uint16_t)f->param;
		}
	}
}

int rmd_sim_faults_set(struct rmd_sim_faults *fs, const struct rmd_sim_fault *faults, size_t n)
{
	if (n > RMD_SIM_MAX_FAULTS)
		return -E2BIG;
	for (size_t k = 0; k < n; k++)
		if (rmd_sim_fault_check(&faults[k]) < 0)
			return -EINVAL;
	rmd_sim_faults_init(fs);
	if (n)
		memcpy(fs->f, faults, n * sizeof(*faults));
	fs->n = (unsigned)n;
	return 0;
}

uint32_t rmd_sim_faults_update(struct rmd_sim_faults *fs, int64_t t, uint64_t *counts)
{
	uint32_t changed = 0;

	/* Between two edges nothing changes (time runs back only after a set). */
	if (t >= fs->last_ns && t < fs->next_edge_ns)
		return 0;
	fs->last_ns = t;
	fs->next_edge_ns = next_edge(fs, t);
	for (unsigned k = 0; k < fs->n; k++) {
		const struct rmd_sim_fault *f = &fs->f[k];
		bool open;

		if (!rmd_sim_fault_is_window(f->kind))
			continue;
		open = window_open(f, t);
		if (open == fs->open[k])
			continue;
		fs->open[k] = open;
		changed |= UINT32_C(1) << k;
		if (!open)
			continue;
		if (f->kind == RMD_SIM_FAULT_FLOOD)
			fs->flood_next_ns[k] = f->start_ns; /* FLOOD counts frames, not windows */
		else
			counts[f->kind]++;
	}
	if (changed)
		refresh(fs);
	return changed;
}

/*
 * The same kind of identifier for motor `other` (WRONG_ID): V2 replies on
 * 0x140 + ID, V3 on 0x240 + ID, MIT on 0x500 + ID.  False for one that
 * carries no ID (0x300 and the like).
 */
static bool retarget(uint32_t *can_id, unsigned other)
{
	static const uint32_t bases[] = { RMD_CAN_REQ_BASE, RMD_CAN_V3_REPLY_BASE,
					  RMD_CAN_MIT_REPLY_BASE };

	for (size_t i = 0; i < sizeof(bases) / sizeof(bases[0]); i++) {
		if (*can_id > bases[i] && *can_id <= bases[i] + RMD_MAX_MOTORS) {
			*can_id = bases[i] + other;
			return true;
		}
	}
	return false;
}

bool rmd_sim_faults_frame(struct rmd_sim_faults *fs, uint64_t *rng, uint8_t motor_id, int64_t t,
			  struct rmd_frame *f, int64_t *ready_ns, uint64_t *counts)
{
	for (unsigned k = 0; k < fs->n; k++) {
		const struct rmd_sim_fault *ft = &fs->f[k];

		if (rmd_sim_fault_is_window(ft->kind) || !rmd_sim_fault_hits(ft, motor_id) ||
		    !window_open(ft, t))
			continue;
		/* only the answers to one command, at most count of them */
		if ((ft->cmd && (!f->len || f->data[0] != ft->cmd)) ||
		    (ft->count && fs->hits[k] >= ft->count))
			continue;
		if (!rmd_rng_roll(rng, ft->probability))
			continue;
		fs->hits[k]++;
		switch (ft->kind) {
		case RMD_SIM_FAULT_DROP:
			counts[ft->kind]++;
			return false;
		case RMD_SIM_FAULT_DELAY:
			*ready_ns += ft->param;
			break;
		case RMD_SIM_FAULT_BAD_DLC:
			f->len = (uint8_t)ft->param;
			break;
		case RMD_SIM_FAULT_GARBAGE:
			for (unsigned j = 0; j < RMD_FRAME_LEN; j++)
				f->data[j] = (uint8_t)rmd_rng_next(rng);
			break;
		case RMD_SIM_FAULT_WRONG_ID:
			if (!retarget(&f->can_id, (unsigned)ft->param))
				continue; /* not hit */
			break;
		case RMD_SIM_FAULT_DISAPPEAR:
		case RMD_SIM_FAULT_ERROR_FLAG:
		case RMD_SIM_FAULT_BUS_OFF:
		case RMD_SIM_FAULT_FLOOD:
		case RMD_SIM_FAULT_BUS_POWER:
		case RMD_SIM_FAULT_COUNT:
			continue;
		}
		counts[ft->kind]++;
	}
	return true;
}

bool rmd_sim_faults_flood_due(const struct rmd_sim_faults *fs, unsigned k, int64_t t)
{
	return k < fs->n && fs->open[k] && fs->f[k].kind == RMD_SIM_FAULT_FLOOD &&
	       fs->flood_next_ns[k] <= t;
}

int64_t rmd_sim_faults_flood_take(struct rmd_sim_faults *fs, unsigned k, uint64_t *rng,
				  struct rmd_frame *f, uint64_t *counts)
{
	int64_t due = fs->flood_next_ns[k];

	f->can_id = fs->f[k].can_id;
	f->len = RMD_FRAME_LEN;
	for (unsigned j = 0; j < RMD_FRAME_LEN; j++)
		f->data[j] = (uint8_t)rmd_rng_next(rng);
	fs->flood_next_ns[k] += fs->f[k].param;
	counts[RMD_SIM_FAULT_FLOOD]++;
	return due;
}

int64_t rmd_sim_faults_next_ns(const struct rmd_sim_faults *fs, int64_t t)
{
	int64_t n = t == fs->last_ns ? fs->next_edge_ns : next_edge(fs, t);

	for (unsigned k = 0; k < fs->n; k++)
		if (fs->open[k] && fs->f[k].kind == RMD_SIM_FAULT_FLOOD &&
		    fs->flood_next_ns[k] > t && fs->flood_next_ns[k] < n)
			n = fs->flood_next_ns[k];
	return n;
}
