// SPDX-License-Identifier: MIT
/*
 * Configuration file: YAML -> struct rmd_config (rmd/config.h).  Non-rt.
 *
 * Three steps:
 * 1. libyaml's event parser builds a small tree of the document whose
 *    nodes keep their line numbers (tree_load).  A syntax error is reported
 *    with the key path of the node being parsed.
 * 2. The tree is walked against schema tables (struct field): each key is
 *    looked up, its value converted, range checked and stored at its
 *    offset in the target struct; unknown and duplicate keys are refused.
 * 3. Checks across keys (validate_*): a motor's bus exists, IDs are unique
 *    per bus, names are unique, protocol and mode agree, ranges are
 *    ordered, keys belong to the bus type; sim buses get their motors'
 *    model parameters.
 * Every error goes through report(): "FILE:LINE: key.path: message".
 *
 * libcyaml (schema-driven too) was the other candidate: its 1.3 loader
 * keeps no positions for the values it stores and has no ranges or
 * defaults, so checks after the load could not name a line.
 */
#include <errno.h>
#include <math.h>
#include <stdarg.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <strings.h>

#include <yaml.h>

#include "rmd/err.h"
#include "rmd/bus_sim.h"
#include "rmd/config.h"
#include "rmd/rs485.h"

#define MAX_ERRORS 32  /* error lines kept in err */
#define MAX_DEPTH 32   /* YAML nesting refused beyond this */
#define PATH_LEN 192   /* "buses[12].sim.faults[31].probability" */
#define MAX_ANCHORS 64 /* anchors remembered for aliases */

/* ------------------------------------------------------------------ */
/* The document tree */

enum ykind { Y_SCALAR, Y_MAP, Y_SEQ };

struct ynode {
	enum ykind kind;
	unsigned line; /* 1-based */
	char *str;     /* Y_SCALAR */
	bool plain;    /* unquoted, untagged: may be a number, bool or null */
	bool open;     /* a container still being parsed */
	/* Y_MAP: key, value, key, value, ...; Y_SEQ: items */
	struct ynode **kids;
	unsigned n, cap;
	struct ynode *next_alloc; /* every node, for freeing */
};

struct ytree {
	struct ynode *root;
	struct ynode *all;
	struct {
		char *name;
		struct ynode *node;
	} anchors[MAX_ANCHORS];
	unsigned n_anchors;
};

/* Error collector. */
struct ctx {
	const char *file;
	char *err;
	size_t errlen;
	size_t used;
	unsigned nerr;
	/* Entries whose own keys had errors: checks across keys skip them. */
	uint32_t bad_bus, bad_motor;
};

__attribute__((format(printf, 4, 5))) static void report(struct ctx *c, unsigned line,
							 const char *path, const char *fmt, ...)
{
	char msg[512];
	va_list ap;
	int n;

	c->nerr++;
	if (!c->err || c->errlen == 0 || c->nerr > MAX_ERRORS + 1)
		return;
	if (c->nerr == MAX_ERRORS + 1) {
		snprintf(msg, sizeof(msg), "%s: more errors not shown", c->file);
	} else {
		size_t k;

		if (line)
			k = (size_t)snprintf(msg, sizeof(msg), "%s:%u: ", c->file, line);
		else
			k = (size_t)snprintf(msg, sizeof(msg), "%s: ", c->file);
		if (path && *path && k < sizeof(msg))
			k += (size_t)snprintf(msg + k, sizeof(msg) - k, "%s: ", path);
		if (k < sizeof(msg)) {
			va_start(ap, fmt);
			vsnprintf(msg + k, sizeof(msg) - k, fmt, ap);
			va_end(ap);
		}
	}
	if (c->used + 1 >= c->errlen)
		return;
	n = snprintf(c->err + c->used, c->errlen - c->used, "%s%s", c->used ? "\n" : "", msg);
	if (n > 0)
		c->used += (size_t)n;
	if (c->used >= c->errlen)
		c->used = c->errlen - 1;
}

static struct ynode *node_new(struct ytree *t, enum ykind kind, unsigned line)
{
	struct ynode *n = calloc(1, sizeof(*n));

	if (!n)
		return NULL;
	n->kind = kind;
	n->line = line;
	n->next_alloc = t->all;
	t->all = n;
	return n;
}

static void tree_free(struct ytree *t)
{
	struct ynode *n = t->all, *next;

	while (n) {
		next = n->next_alloc;
		free(n->str);
		free(n->kids);
		free(n);
		n = next;
	}
	for (unsigned i = 0; i < t->n_anchors; i++)
		free(t->anchors[i].name);
	memset(t, 0, sizeof(*t));
}

static int node_add(struct ynode *parent, struct ynode *kid)
{
	if (parent->n == parent->cap) {
		unsigned cap = parent->cap ? 2 * parent->cap : 8;
		struct ynode **k = realloc(parent->kids, cap * sizeof(*k));

		if (!k)
			return -ENOMEM;
		parent->kids = k;
		parent->cap = cap;
	}
	parent->kids[parent->n++] = kid;
	return 0;
}

static int anchor_add(struct ytree *t, const yaml_char_t *name, struct ynode *node)
{
	if (!name)
		return 0;
	if (t->n_anchors == MAX_ANCHORS)
		return -E2BIG;
	t->anchors[t->n_anchors].name = strdup((const char *)name);
	if (!t->anchors[t->n_anchors].name)
		return -ENOMEM;
	t->anchors[t->n_anchors++].node = node;
	return 0;
}

static struct ynode *anchor_find(const struct ytree *t, const yaml_char_t *name)
{
	for (unsigned i = t->n_anchors; i-- > 0;)
		if (!strcmp(t->anchors[i].name, (const char *)name))
			return t->anchors[i].node;
	return NULL;
}

/* A map's key scalar, or "?" for a key that is not a scalar. */
static const char *key_str(const struct ynode *k)
{
	return k->kind == Y_SCALAR ? k->str : "?";
}

/* The key path of the place the parser is at: the open containers. */
static void stack_path(struct ynode *const *stack, unsigned depth, char *path, size_t len)
{
	size_t k = 0;

	path[0] = '\0';
	for (unsigned i = 0; i < depth && k < len; i++) {
		const struct ynode *n = stack[i];
		bool top = i + 1 == depth;

		if (n->kind == Y_MAP && n->n > 0 && (n->n % 2 || !top)) {
			/*
			 * Odd: a key waits for its value.  Even: the last value
			 * is the open container below, or, at the top, the
			 * error is in a key yet to come: the map's own path.
			 */
			unsigned ki = (n->n % 2) ? n->n - 1 : n->n - 2;

			k += (size_t)snprintf(path + k, len - k, "%s%s", k ? "." : "",
					      key_str(n->kids[ki]));
		} else if (n->kind == Y_SEQ) {
			unsigned idx = top ? n->n : (n->n ? n->n - 1 : 0);

			k += (size_t)snprintf(path + k, len - k, "[%u]", idx);
		}
	}
}

/*
 * Parse the whole file into t.  Returns 0, or -EINVAL after reporting a
 * syntax error, or -ENOMEM.
 */
static int tree_load(struct ctx *c, FILE *f, struct ytree *t)
{
	struct ynode *stack[MAX_DEPTH];
	unsigned depth = 0, docs = 0;
	yaml_parser_t p;
	yaml_event_t ev;
	int ret = 0;
	bool done = false;

	if (!yaml_parser_initialize(&p))
		return -ENOMEM;
	yaml_parser_set_input_file(&p, f);
	while (!done) {
		struct ynode *node = NULL;
		unsigned line;

		if (!yaml_parser_parse(&p, &ev)) {
			char path[PATH_LEN];

			stack_path(stack, depth, path, sizeof(path));
			if (p.context)
				report(c, (unsigned)p.problem_mark.line + 1, path,
				       "syntax error: %s (%s at line %u)", p.problem, p.context,
				       (unsigned)p.context_mark.line + 1);
			else
				report(c, (unsigned)p.problem_mark.line + 1, path,
				       "syntax error: %s",
				       p.problem ? p.problem : "unreadable input");
			ret = -EINVAL;
			break;
		}
		line = (unsigned)ev.start_mark.line + 1;
		switch (ev.type) {
		case YAML_NO_EVENT:
		case YAML_STREAM_START_EVENT:
		case YAML_DOCUMENT_END_EVENT:
			break;
		case YAML_STREAM_END_EVENT:
			done = true;
			break;
		case YAML_DOCUMENT_START_EVENT:
			if (++docs > 1) {
				report(c, line, "", "a second YAML document: the file holds one");
				ret = -EINVAL;
				done = true;
			}
			break;
		case YAML_ALIAS_EVENT:
			node = anchor_find(t, ev.data.alias.anchor);
			if (!node || node->open) {
				char path[PATH_LEN];

				stack_path(stack, depth, path, sizeof(path));
				report(c, line, path,
				       "alias *%s names no complete anchor before it",
				       (const char *)ev.data.alias.anchor);
				ret = -EINVAL;
				done = true;
				node = NULL;
			}
			break;
		case YAML_SCALAR_EVENT:
			node = node_new(t, Y_SCALAR, line);
			if (!node)
				break;
			node->str = strdup((const char *)ev.data.scalar.value);
			node->plain = ev.data.scalar.style == YAML_PLAIN_SCALAR_STYLE &&
				      !ev.data.scalar.tag;
			if (!node->str || anchor_add(t, ev.data.scalar.anchor, node))
				node = NULL;
			break;
		case YAML_SEQUENCE_START_EVENT:
		case YAML_MAPPING_START_EVENT:
			node = node_new(t, ev.type == YAML_SEQUENCE_START_EVENT ? Y_SEQ : Y_MAP,
					line);
			if (!node)
				break;
			node->open = true;
			if (anchor_add(t,
				       ev.type == YAML_SEQUENCE_START_EVENT ?
					       ev.data.sequence_start.anchor :
					       ev.data.mapping_start.anchor,
				       node))
				node = NULL;
			break;
		case YAML_SEQUENCE_END_EVENT:
		case YAML_MAPPING_END_EVENT:
			if (depth > 0)
				stack[--depth]->open = false;
			break;
		}
		if (ret == 0 && !done && !node &&
		    (ev.type == YAML_SCALAR_EVENT || ev.type == YAML_SEQUENCE_START_EVENT ||
		     ev.type == YAML_MAPPING_START_EVENT)) {
			ret = -ENOMEM;
			done = true;
		}
		if (node) {
			if (depth == 0)
				t->root = node;
			else if (node_add(stack[depth - 1], node))
				ret = -ENOMEM, done = true;
			if (node->open && !done) {
				if (depth == MAX_DEPTH) {
					report(c, line, "", "nested deeper than %d levels",
					       MAX_DEPTH);
					ret = -EINVAL;
					done = true;
				} else {
					stack[depth++] = node;
				}
			}
		}
		yaml_event_delete(&ev);
	}
	yaml_parser_delete(&p);
	return ret;
}

/* The value of `key` in map m (NULL if absent), and the key's line. */
static const struct ynode *map_get(const struct ynode *m, const char *key, unsigned *key_line)
{
	if (!m || m->kind != Y_MAP)
		return NULL;
	for (unsigned i = 0; i + 1 < m->n; i += 2) {
		const struct ynode *k = m->kids[i];

		if (k->kind == Y_SCALAR && !strcmp(k->str, key)) {
			if (key_line)
				*key_line = k->line;
			return m->kids[i + 1];
		}
	}
	return NULL;
}

/* Line of key's value in m, or of m when the key is absent. */
static unsigned line_of(const struct ynode *m, const char *key)
{
	const struct ynode *v = map_get(m, key, NULL);

	return v ? v->line : (m ? m->line : 1);
}

static bool is_null(const struct ynode *n)
{
	return n->kind == Y_SCALAR && n->plain &&
	       (!n->str[0] || !strcmp(n->str, "~") || !strcasecmp(n->str, "null"));
}

static const char *kind_desc(const struct ynode *n)
{
	switch (n->kind) {
	case Y_SCALAR:
		return "a scalar";
	case Y_MAP:
		return "a mapping";
	case Y_SEQ:
		return "a sequence";
	}
	return "?";
}

/* ------------------------------------------------------------------ */
/* Schema */

enum ftype {
	T_UINT,	  /* unsigned integer of `size` bytes */
	T_INT,	  /* signed integer of `size` bytes (enums are T_ENUM) */
	T_DOUBLE, /* double, finite, stored times `scale` */
	T_NS,	  /* int64_t, the value times `scale` rounded (seconds, us -> ns) */
	T_BOOL,
	T_STR,	/* char[size], NUL included */
	T_ENUM, /* int-sized enum: index into names */
	T_MAP,	/* the struct at off, members in sub */
	T_SEQ,	/* array at off of up to `size` elements described by elem */
	T_LATER /* allowed key, handled by validate_*() */
};

/* Field flags */
enum {
	F_REQUIRED = 1u << 0,
	F_MIN_EXCL = 1u << 1, /* value > min rather than >= min */
	F_IDENT = 1u << 2,    /* T_STR: [a-z0-9_]+ */
	F_SIGN = 1u << 3,     /* T_INT: -1 or +1 */
};

struct field {
	const char *key;
	enum ftype type;
	unsigned flags;
	size_t off;
	size_t size; /* see enum ftype */
	double min, max;
	double scale;		  /* T_DOUBLE, T_NS: 0 means 1 */
	const char *const *names; /* T_ENUM, NULL-terminated */
	const struct field *sub;  /* T_MAP: members, key NULL at the end */
	/* T_SEQ */
	const struct field *elem; /* the element: T_MAP or a scalar type, off 0 */
	size_t elem_size;
	size_t count_off; /* unsigned in the parent struct */
	void (*init)(void *elem);
	const char *why; /* appended to a range error */
};

#define SZ(st, m) sizeof(((st *)0)->m)
#define UINT(k, st, m, lo, hi, fl)                                                                \
	{                                                                                         \
		.key = k, .type = T_UINT, .flags = fl, .off = offsetof(st, m), .size = SZ(st, m), \
		.min = lo, .max = hi                                                              \
	}
#define UINTW(k, st, m, lo, hi, w)                                                              \
	{                                                                                       \
		.key = k, .type = T_UINT, .off = offsetof(st, m), .size = SZ(st, m), .min = lo, \
		.max = hi, .why = w                                                             \
	}
#define INT(k, st, m, lo, hi, fl)                                                                \
	{                                                                                        \
		.key = k, .type = T_INT, .flags = fl, .off = offsetof(st, m), .size = SZ(st, m), \
		.min = lo, .max = hi                                                             \
	}
#define DBL(k, st, m, lo, hi, fl)                                                           \
	{                                                                                   \
		.key = k, .type = T_DOUBLE, .flags = fl, .off = offsetof(st, m), .min = lo, \
		.max = hi                                                                   \
	}
#define DBLS(k, st, m, lo, hi, fl, sc)                                                      \
	{                                                                                   \
		.key = k, .type = T_DOUBLE, .flags = fl, .off = offsetof(st, m), .min = lo, \
		.max = hi, .scale = sc                                                      \
	}
#define NS(k, st, m, lo, hi, sc)                                                                  \
	{                                                                                         \
		.key = k, .type = T_NS, .off = offsetof(st, m), .min = lo, .max = hi, .scale = sc \
	}
#define BOOL(k, st, m)                                           \
	{                                                        \
		.key = k, .type = T_BOOL, .off = offsetof(st, m) \
	}
#define STR(k, st, m, fl)                                                                       \
	{                                                                                       \
		.key = k, .type = T_STR, .flags = fl, .off = offsetof(st, m), .size = SZ(st, m) \
	}
#define ENUM(k, st, m, nm, fl)                                                                    \
	{                                                                                         \
		.key = k, .type = T_ENUM, .flags = fl, .off = offsetof(st, m), .size = SZ(st, m), \
		.names = nm                                                                       \
	}
#define MAP(k, st, m, members)                                                  \
	{                                                                       \
		.key = k, .type = T_MAP, .off = offsetof(st, m), .sub = members \
	}
#define SEQ(k, st, m, cnt, el, ini)                                                               \
	{                                                                                         \
		.key = k, .type = T_SEQ, .off = offsetof(st, m),                                  \
		.size = sizeof(((st *)0)->m) / sizeof(((st *)0)->m[0]), .elem = el,               \
		.elem_size = sizeof(((st *)0)->m[0]), .count_off = offsetof(st, cnt), .init = ini \
	}
#define LATER(k)                          \
	{                                 \
		.key = k, .type = T_LATER \
	}
#define END                 \
	{                   \
		.key = NULL \
	}

static const char *const bus_kind_names[] = { "socketcan", "rs485", "sim", NULL };
static const char *const mode_names[] = { "torque", "speed", "position", "mit", NULL };
static const char *const units_names[] = { "output", "rotor", NULL };
static const char *const safe_names[] = { "stop", "hold", "damp", "brake", NULL };
static const char *const lost_names[] = { "motor", "all", NULL };
static const char *const missing_names[] = { "refuse", "start", NULL };
/* In the order of enum rmd_sim_fault_kind, as rmd_sim_fault_kind_name() spells them. */
static const char *const fault_names[] = { "drop",     "delay",	    "bad_dlc",	  "garbage",
					   "wrong_id", "disappear", "error_flag", "bus_off",
					   "flood",    NULL };
_Static_assert(sizeof(fault_names) / sizeof(fault_names[0]) == RMD_SIM_FAULT_COUNT + 1,
	       "fault_names[] follows enum rmd_sim_fault_kind");

static const char prio_why[] =
	"the kernel's IRQ threads run at SCHED_FIFO 50 and deliver this loop's own replies; a "
	"loop at 50 or above starves them (DESIGN.md), and 99 is the kernel's own level";

static const struct field loop_fields[] = {
	UINT("rate_hz", struct rmd_config_loop, rate_hz, 1, RMD_CONFIG_RATE_MAX_HZ, 0),
	UINTW("rt_priority", struct rmd_config_loop, rt_priority, 1, RMD_CONFIG_PRIO_MAX, prio_why),
	{ .key = "cpu_affinity",
	  .type = T_SEQ,
	  .off = offsetof(struct rmd_config_loop, cpus),
	  .size = RMD_CONFIG_MAX_CPUS,
	  .elem = &(const struct field){ .type = T_UINT, .size = sizeof(uint16_t), .max = 1023 },
	  .elem_size = sizeof(uint16_t),
	  .count_off = offsetof(struct rmd_config_loop, n_cpus) },
	END
};

static const struct field safety_fields[] = {
	UINT("comm_loss_ms", struct rmd_config_safety, comm_loss_ms, 0, 600000, 0),
	UINT("missed_replies_lost", struct rmd_config_safety, missed_replies_lost, 1, 10000, 0),
	UINT("command_timeout_ms", struct rmd_config_safety, command_timeout_ms, 1, 600000, 0),
	ENUM("safe_action", struct rmd_config_safety, safe_action, safe_names, 0),
	ENUM("lost_motor_action", struct rmd_config_safety, lost_motor_action, lost_names, 0),
	END
};

static const struct field probe_fields[] = {
	ENUM("on_missing", struct rmd_config_probe, on_missing, missing_names, 0), END
};

static const struct field lcm_fields[] = {
	STR("url", struct rmd_config_lcm, url, 0),
	STR("channel_prefix", struct rmd_config_lcm, channel_prefix, 0),
	UINT("state_every_n", struct rmd_config_lcm, state_every_n, 1, 10000, 0),
	UINT("stale_ms", struct rmd_config_lcm, stale_ms, 0, 600000, 0),
	UINT("health_period_ms", struct rmd_config_lcm, health_period_ms, 10, 600000, 0),
	END
};

/* The simulated motor's model: bus-wide (sim.motor) or per motor (motors[].sim). */
#define P struct rmd_sim_motor_params
static const struct field sim_motor_fields[] = {
	DBL("inertia_kgm2", P, inertia_kgm2, 0, 1000, F_MIN_EXCL),
	DBL("viscous_nm_s_rad", P, viscous_nm_s_rad, 0, 1e4, 0),
	DBL("coulomb_nm", P, coulomb_nm, 0, 1e4, 0),
	UINT("pole_pairs", P, pole_pairs, 1, 100, 0),
	DBL("max_current_a", P, max_current_a, 0, 1000, F_MIN_EXCL),
	DBL("load_nm", P, load_nm, -1e4, 1e4, 0),
	DBL("max_speed_dps", P, max_speed_dps, 0, 1e6, F_MIN_EXCL),
	DBL("fw_max_speed_dps", P, fw_max_speed_dps, 0, 1e6, F_MIN_EXCL),
	DBL("phase_resistance_ohm", P, phase_resistance_ohm, 0, 100, 0),
	DBL("thermal_resistance_c_w", P, thermal_resistance_c_w, 0, 1000, F_MIN_EXCL),
	DBL("thermal_tau_s", P, thermal_tau_s, 0, 1e6, F_MIN_EXCL),
	DBL("ambient_c", P, ambient_c, -60, 150, 0),
	DBL("supply_v", P, supply_v, 0, 200, 0),
	DBL("over_temp_c", P, over_temp_c, -60, 250, 0),
	DBL("over_temp_clear_c", P, over_temp_clear_c, -60, 250, 0),
	DBL("under_voltage_v", P, under_voltage_v, 0, 200, 0),
	DBL("over_voltage_v", P, over_voltage_v, 0, 200, 0),
	DBL("stall_time_s", P, stall_time_s, 0, 1e4, F_MIN_EXCL),
	BOOL("has_brake", P, has_brake),
	UINT("encoder_bits", P, encoder_bits, 8, 24, 0),
	STR("model", P, model, 0),
	UINT("version_date", P, version_date, 19700101, 29991231, 0),
	DBLS("turnaround_us", P, turnaround_ns, 0, 1e6, 0, 1000.0),
	DBLS("turnaround_jitter_us", P, turnaround_jitter_ns, 0, 1e6, 0, 1000.0),
	UINT("seed", P, seed, 0, 18446744073709551615.0, 0),
	END
};
#undef P

static void fault_init(void *elem)
{
	struct rmd_sim_fault *f = elem;

	memset(f, 0, sizeof(*f));
	f->probability = 1.0;
}

#define F struct rmd_sim_fault
static const struct field fault_fields[] = { ENUM("kind", F, kind, fault_names, F_REQUIRED),
					     UINT("motor", F, motor_id, 0, RMD_MAX_MOTORS, 0),
					     DBL("probability", F, probability, 0, 1, 0),
					     NS("start_s", F, start_ns, 0, 1e6, 1e9),
					     NS("end_s", F, end_ns, 0, 1e6, 1e9),
					     INT("param", F, param, -1e15, 1e15, 0),
					     UINT("can_id", F, can_id, 0, 0x7FF, 0),
					     END };
#undef F

static const struct field fault_elem = { .type = T_MAP, .sub = fault_fields };

#define S struct rmd_config_sim
static const struct field sim_fields[] = { UINT("seed", S, seed, 0, 18446744073709551615.0, 0),
					   UINT("txqueuelen", S, txqueuelen, 1, RMD_SIM_BUS_TXQ, 0),
					   BOOL("host_fifo", S, host_fifo),
					   MAP("motor", S, motor, sim_motor_fields),
					   SEQ("faults", S, faults, n_faults, &fault_elem,
					       fault_init),
					   END };
#undef S

#define B struct rmd_config_bus
static const struct field bus_fields[] = { STR("name", B, name, F_REQUIRED | F_IDENT),
					   ENUM("type", B, kind, bus_kind_names, F_REQUIRED),
					   STR("interface", B, interface, 0),
					   STR("device", B, device, 0),
					   UINT("baud", B, baud, 1, 100000000, 0),
					   UINT("bitrate", B, bitrate, 1, 100000000, 0),
					   NS("turnaround_us", B, turnaround_ns, 0, 1e6, 1000.0),
					   MAP("sim", B, sim, sim_fields),
					   END };
#undef B

#define L struct rmd_config_limits
static const struct field limits_fields[] = {
	DBL("position_min_rad", L, position_min_rad, -1e6, 1e6, 0),
	DBL("position_max_rad", L, position_max_rad, -1e6, 1e6, 0),
	DBL("velocity_rad_s", L, velocity_rad_s, 0, 1e4, F_MIN_EXCL),
	DBL("torque_nm", L, torque_nm, 0, 1e5, F_MIN_EXCL), END
};
#undef L

#define R struct rmd_mit_ranges
static const struct field mit_fields[] = { DBL("p_min", R, p_min, -1e6, 1e6, 0),
					   DBL("p_max", R, p_max, -1e6, 1e6, 0),
					   DBL("v_min", R, v_min, -1e6, 1e6, 0),
					   DBL("v_max", R, v_max, -1e6, 1e6, 0),
					   DBL("t_min", R, t_min, -1e6, 1e6, 0),
					   DBL("t_max", R, t_max, -1e6, 1e6, 0),
					   DBL("kp_min", R, kp_min, 0, 1e6, 0),
					   DBL("kp_max", R, kp_max, 0, 1e6, 0),
					   DBL("kd_min", R, kd_min, 0, 1e6, 0),
					   DBL("kd_max", R, kd_max, 0, 1e6, 0),
					   END };
#undef R

#define M struct rmd_config_motor
static const struct field motor_fields[] = {
	STR("name", M, name, F_REQUIRED | F_IDENT),
	LATER("bus"),
	UINT("id", M, id, 1, RMD_MAX_MOTORS, F_REQUIRED),
	ENUM("protocol", M, proto, rmd_proto_keys, 0),
	ENUM("mode", M, mode, mode_names, F_REQUIRED),
	INT("direction", M, direction, -1, 1, F_SIGN),
	DBL("gear_ratio", M, gear_ratio, 0, 1e4, F_MIN_EXCL),
	ENUM("units", M, units, units_names, 0),
	DBL("zero_offset_rad", M, zero_offset_rad, -1e6, 1e6, 0),
	DBL("torque_constant_nm_a", M, torque_constant_nm_a, 0, 1e4, F_MIN_EXCL),
	MAP("limits", M, limits, limits_fields),
	MAP("mit", M, mit, mit_fields),
	UINT("rate_divisor", M, rate_divisor, 1, RMD_CONFIG_DIVISOR_MAX, 0),
	DBL("status_poll_hz", M, status_poll_hz, 0, RMD_CONFIG_RATE_MAX_HZ, 0),
	LATER("sim"),
	END
};
#undef M

static void bus_init(void *elem)
{
	struct rmd_config_bus *b = elem;

	memset(b, 0, sizeof(*b));
	b->bitrate = RMD_CONFIG_DEFAULT_BITRATE;
	b->baud = RMD_CONFIG_DEFAULT_BAUD;
	b->turnaround_ns = RMD_CONFIG_DEFAULT_RS485_TURNAROUND_NS;
	b->sim.seed = 1;
	b->sim.txqueuelen = RMD_CONFIG_DEFAULT_SIM_TXQUEUELEN;
	b->sim.host_fifo = true;
	rmd_sim_motor_params_default(&b->sim.motor, 1, RMD_PROTO_V3);
}

static void motor_init(void *elem)
{
	struct rmd_config_motor *m = elem;

	memset(m, 0, sizeof(*m));
	m->proto = RMD_PROTO_V3;
	m->mode = RMD_CTRL_TORQUE;
	m->direction = 1;
	m->gear_ratio = 1.0;
	m->units = RMD_UNITS_OUTPUT;
	m->limits.position_min_rad = -INFINITY;
	m->limits.position_max_rad = INFINITY;
	m->limits.velocity_rad_s = INFINITY;
	m->limits.torque_nm = INFINITY;
	m->mit = rmd_mit_default_ranges;
	m->rate_divisor = 1;
	m->status_poll_hz = RMD_CONFIG_DEFAULT_STATUS_POLL_HZ;
}

static const struct field bus_elem = { .type = T_MAP, .sub = bus_fields };
static const struct field motor_elem = { .type = T_MAP, .sub = motor_fields };

#define C struct rmd_config
static const struct field top_fields[] = { MAP("loop", C, loop, loop_fields),
					   MAP("safety", C, safety, safety_fields),
					   MAP("probe", C, probe, probe_fields),
					   MAP("lcm", C, lcm, lcm_fields),
					   SEQ("buses", C, buses, n_buses, &bus_elem, bus_init),
					   SEQ("motors", C, motors, n_motors, &motor_elem,
					       motor_init),
					   END };
#undef C

/* ------------------------------------------------------------------ */
/* Walking the tree against the schema */

/* path.key and path[i]; a path too long for PATH_LEN is cut. */
static void path_key(char *out, const char *path, const char *key)
{
	if (snprintf(out, PATH_LEN, "%s%s%s", path, *path ? "." : "", key) >= PATH_LEN)
		out[PATH_LEN - 1] = '\0';
}

static void path_idx(char *out, const char *path, unsigned i)
{
	if (snprintf(out, PATH_LEN, "%s[%u]", path, i) >= PATH_LEN)
		out[PATH_LEN - 1] = '\0';
}

/* "a, b, c" of a NULL-terminated list, or of a field table's keys. */
static void join_names(char *out, size_t len, const char *const *names, const struct field *fields)
{
	size_t k = 0;

	out[0] = '\0';
	for (unsigned i = 0;; i++) {
		const char *s = names ? names[i] : fields[i].key;

		if (!s || k >= len)
			break;
		k += (size_t)snprintf(out + k, len - k, "%s%s", i ? ", " : "", s);
	}
}

static void store_uint(void *dst, size_t size, uint64_t v)
{
	switch (size) {
	case 1: {
		uint8_t x = (uint8_t)v;
		memcpy(dst, &x, 1);
		break;
	}
	case 2: {
		uint16_t x = (uint16_t)v;
		memcpy(dst, &x, 2);
		break;
	}
	case 4: {
		uint32_t x = (uint32_t)v;
		memcpy(dst, &x, 4);
		break;
	}
	default:
		memcpy(dst, &v, 8);
		break;
	}
}

static void store_int(void *dst, size_t size, int64_t v)
{
	switch (size) {
	case 1: {
		int8_t x = (int8_t)v;
		memcpy(dst, &x, 1);
		break;
	}
	case 2: {
		int16_t x = (int16_t)v;
		memcpy(dst, &x, 2);
		break;
	}
	case 4: {
		int32_t x = (int32_t)v;
		memcpy(dst, &x, 4);
		break;
	}
	default:
		memcpy(dst, &v, 8);
		break;
	}
}

/* ".inf", "-.Inf", ".nan", "nan", "infinity": YAML's and strtod's spellings. */
static bool spells_nonfinite(const char *s)
{
	if (*s == '+' || *s == '-')
		s++;
	if (*s == '.')
		s++;
	return !strcasecmp(s, "inf") || !strcasecmp(s, "nan") || !strcasecmp(s, "infinity");
}

/* "1..32", "> 0", ">= 0", ... for a range error. */
static void range_str(char *out, size_t len, const struct field *f)
{
	if (f->flags & F_SIGN)
		snprintf(out, len, "+1 or -1");
	else if (f->flags & F_MIN_EXCL)
		snprintf(out, len, "> %g and <= %g", f->min, f->max);
	else if (f->type == T_UINT || f->type == T_INT)
		snprintf(out, len, "%.0f..%.0f", f->min, f->max);
	else
		snprintf(out, len, "%g..%g", f->min, f->max);
}

static void range_error(struct ctx *c, const struct ynode *v, const struct field *f,
			const char *path)
{
	char r[96];

	range_str(r, sizeof(r), f);
	if (f->why)
		report(c, v->line, path, "%s is out of range (%s): %s", v->str, r, f->why);
	else
		report(c, v->line, path, "%s is out of range (%s)", v->str, r);
}

static bool parse_integer(const char *s, bool is_signed, int64_t *sv, uint64_t *uv)
{
	const char *p = s;
	char *end;
	int base = 10;

	if (*p == '+' || *p == '-')
		p++;
	if (p[0] == '0' && (p[1] == 'x' || p[1] == 'X'))
		base = 16;
	if (!*p || (*s == '-' && !is_signed))
		return false;
	errno = 0;
	if (is_signed)
		*sv = strtoll(s, &end, base);
	else
		*uv = strtoull(*s == '+' ? s + 1 : s, &end, base);
	return end != s && *end == '\0' && errno == 0;
}

static void walk_map(struct ctx *c, const struct ynode *m, const struct field *fields, void *base,
		     const char *path);

static void walk_value(struct ctx *c, const struct ynode *v, const struct field *f, void *dst,
		       const char *path)
{
	char names[512];

	if (f->type == T_LATER)
		return;
	if (f->type == T_MAP) {
		if (is_null(v))
			return;
		if (v->kind != Y_MAP) {
			join_names(names, sizeof(names), NULL, f->sub);
			report(c, v->line, path, "expected a mapping (keys %s), got %s", names,
			       kind_desc(v));
			return;
		}
		walk_map(c, v, f->sub, dst, path);
		return;
	}
	if (f->type == T_SEQ) {
		unsigned n = 0, before;
		char ip[PATH_LEN];

		if (!is_null(v) && v->kind != Y_SEQ) {
			report(c, v->line, path, "expected a sequence (a list), got %s",
			       kind_desc(v));
			return;
		}
		for (unsigned i = 0; !is_null(v) && i < v->n; i++) {
			char *el = (char *)dst + n * f->elem_size;

			if (n == f->size) {
				report(c, v->kids[i]->line, path, "%u entries, at most %zu allowed",
				       v->n, f->size);
				break;
			}
			if (f->init)
				f->init(el);
			path_idx(ip, path, i);
			before = c->nerr;
			walk_value(c, v->kids[i], f->elem, el, ip);
			if (c->nerr != before && f->elem == &bus_elem)
				c->bad_bus |= 1u << n;
			if (c->nerr != before && f->elem == &motor_elem)
				c->bad_motor |= 1u << n;
			n++;
		}
		/* dst is the array; the count lives at count_off of the parent */
		memcpy((char *)dst - f->off + f->count_off, &n, sizeof(n));
		return;
	}
	/* scalars */
	if (v->kind != Y_SCALAR) {
		report(c, v->line, path, "expected a single value, got %s", kind_desc(v));
		return;
	}
	if (is_null(v)) {
		report(c, v->line, path, "a value is required");
		return;
	}
	switch (f->type) {
	case T_UINT:
	case T_INT: {
		int64_t sv = 0;
		uint64_t uv = 0;
		bool sgn = f->type == T_INT;

		if (!v->plain || !parse_integer(v->str, sgn, &sv, &uv)) {
			if (v->plain && !sgn && v->str[0] == '-' &&
			    parse_integer(v->str, true, &sv, &uv)) {
				range_error(c, v, f, path);
				return;
			}
			report(c, v->line, path, "expected an integer, got \"%s\"", v->str);
			return;
		}
		if (sgn ? ((double)sv < f->min || (double)sv > f->max ||
			   ((f->flags & F_SIGN) && sv == 0)) :
			  ((double)uv < f->min || (double)uv > f->max)) {
			range_error(c, v, f, path);
			return;
		}
		if (sgn)
			store_int(dst, f->size, sv);
		else
			store_uint(dst, f->size, uv);
		return;
	}
	case T_DOUBLE:
	case T_NS: {
		char *end;
		double d;

		if (v->plain && spells_nonfinite(v->str)) {
			report(c, v->line, path, "%s is not allowed: a finite number is required",
			       v->str);
			return;
		}
		errno = 0;
		d = v->plain ? strtod(v->str, &end) : 0.0;
		if (!v->plain || end == v->str || *end != '\0') {
			report(c, v->line, path, "expected a number, got \"%s\"", v->str);
			return;
		}
		if (errno == ERANGE && fabs(d) > 1.0) {
			report(c, v->line, path, "%s is too large: a finite number is required",
			       v->str);
			return;
		}
		if (!isfinite(d) || d < f->min || d > f->max ||
		    ((f->flags & F_MIN_EXCL) && d <= f->min)) {
			range_error(c, v, f, path);
			return;
		}
		d *= f->scale != 0.0 ? f->scale : 1.0;
		if (f->type == T_NS) {
			int64_t ns = llround(d);

			memcpy(dst, &ns, sizeof(ns));
		} else {
			memcpy(dst, &d, sizeof(d));
		}
		return;
	}
	case T_BOOL: {
		static const char *const yes[] = { "true", "yes", "on" };
		static const char *const no[] = { "false", "no", "off" };
		bool b = false, ok = false;

		for (unsigned i = 0; v->plain && i < 3; i++) {
			if (!strcasecmp(v->str, yes[i]))
				b = true, ok = true;
			if (!strcasecmp(v->str, no[i]))
				ok = true;
		}
		if (!ok) {
			report(c, v->line, path, "expected true or false, got \"%s\"", v->str);
			return;
		}
		memcpy(dst, &b, sizeof(b));
		return;
	}
	case T_STR: {
		size_t len = strlen(v->str);

		if (len >= f->size) {
			report(c, v->line, path, "\"%s\" is too long (at most %zu characters)",
			       v->str, f->size - 1);
			return;
		}
		if (f->flags & F_IDENT) {
			if (!len ||
			    strspn(v->str, "abcdefghijklmnopqrstuvwxyz0123456789_") != len) {
				report(c, v->line, path,
				       "\"%s\" is not a name: use lower-case letters, digits and _",
				       v->str);
				return;
			}
		}
		memcpy(dst, v->str, len + 1);
		return;
	}
	case T_ENUM:
		for (int i = 0; f->names[i]; i++) {
			if (!strcmp(v->str, f->names[i])) {
				store_int(dst, f->size, i);
				return;
			}
		}
		join_names(names, sizeof(names), f->names, NULL);
		report(c, v->line, path, "\"%s\" is not one of %s", v->str, names);
		return;
	case T_MAP:
	case T_SEQ:
	case T_LATER:
		break;
	}
}

/* Edit distance of a and b (insert, delete, replace), up to 63 characters each. */
static unsigned edit_distance(const char *a, const char *b)
{
	unsigned row[64], n = (unsigned)strlen(b), m = (unsigned)strlen(a);

	if (n > 63 || m > 63)
		return 99;
	for (unsigned j = 0; j <= n; j++)
		row[j] = j;
	for (unsigned i = 1; i <= m; i++) {
		unsigned diag = row[0];

		row[0] = i;
		for (unsigned j = 1; j <= n; j++) {
			unsigned up = row[j];
			unsigned best = diag + (a[i - 1] != b[j - 1]);

			if (up + 1 < best)
				best = up + 1;
			if (row[j - 1] + 1 < best)
				best = row[j - 1] + 1;
			row[j] = best;
			diag = up;
		}
	}
	return row[n];
}

/* The allowed key closest to a misspelt one (at most 2 edits), or NULL. */
static const char *nearest_key(const char *key, const struct field *fields)
{
	const char *best = NULL;
	unsigned best_d = 3;

	for (unsigned j = 0; fields[j].key; j++) {
		unsigned d = edit_distance(key, fields[j].key);

		if (d < best_d) {
			best_d = d;
			best = fields[j].key;
		}
	}
	return best;
}

static void walk_map(struct ctx *c, const struct ynode *m, const struct field *fields, void *base,
		     const char *path)
{
	char kp[PATH_LEN], names[512];

	for (unsigned i = 0; i + 1 < m->n; i += 2) {
		const struct ynode *k = m->kids[i], *v = m->kids[i + 1];
		const struct field *f = NULL;

		if (k->kind != Y_SCALAR) {
			report(c, k->line, path, "a key must be a plain name, got %s",
			       kind_desc(k));
			continue;
		}
		path_key(kp, path, k->str);
		for (unsigned j = 0; j < i; j += 2) {
			if (m->kids[j]->kind == Y_SCALAR && !strcmp(m->kids[j]->str, k->str)) {
				report(c, k->line, kp, "duplicate key (first at line %u)",
				       m->kids[j]->line);
				k = NULL;
				break;
			}
		}
		if (!k)
			continue;
		for (unsigned j = 0; fields[j].key; j++)
			if (!strcmp(fields[j].key, k->str))
				f = &fields[j];
		if (!f) {
			const char *near = nearest_key(k->str, fields);

			join_names(names, sizeof(names), NULL, fields);
			if (near)
				report(c, k->line, kp,
				       "unknown key (did you mean %s?); allowed: %s", near, names);
			else
				report(c, k->line, kp, "unknown key; allowed: %s", names);
			continue;
		}
		walk_value(c, v, f, (char *)base + f->off, kp);
	}
	for (unsigned j = 0; fields[j].key; j++) {
		if ((fields[j].flags & F_REQUIRED) && !map_get(m, fields[j].key, NULL)) {
			path_key(kp, path, fields[j].key);
			report(c, m->line, kp, "required key missing");
		}
	}
}

/* ------------------------------------------------------------------ */
/* Checks across keys */

static bool uint_in(uint32_t v, const uint32_t *set, size_t n)
{
	for (size_t i = 0; i < n; i++)
		if (set[i] == v)
			return true;
	return false;
}

/* A key that the bus's type does not use. */
static void bus_key_unused(struct ctx *c, const struct ynode *bn, const char *path, const char *key,
			   const struct rmd_config_bus *b, const char *which)
{
	unsigned kl;
	char kp[PATH_LEN];

	if (!map_get(bn, key, &kl))
		return;
	path_key(kp, path, key);
	report(c, kl, kp, "only for type %s (this bus is %s)", which, rmd_bus_kind_name(b->kind));
}

static void validate_sim_model(struct ctx *c, const struct rmd_sim_motor_params *p,
			       const struct ynode *n, const char *path)
{
	char kp[PATH_LEN];

	if (p->over_temp_clear_c > p->over_temp_c) {
		path_key(kp, path, "over_temp_clear_c");
		report(c, line_of(n, "over_temp_clear_c"), kp,
		       "%g is above over_temp_c (%g): the fault would never clear",
		       p->over_temp_clear_c, p->over_temp_c);
	}
	if (p->under_voltage_v >= p->over_voltage_v) {
		path_key(kp, path, "under_voltage_v");
		report(c, line_of(n, "under_voltage_v"), kp, "%g must be below over_voltage_v (%g)",
		       p->under_voltage_v, p->over_voltage_v);
	}
}

static void validate_buses(struct ctx *c, struct rmd_config *cfg, const struct ynode *seq)
{
	static const uint32_t can_rates[] = { 500000, 1000000 };
	char path[PATH_LEN], kp[PATH_LEN];

	for (unsigned i = 0; i < cfg->n_buses; i++) {
		struct rmd_config_bus *b = &cfg->buses[i];
		const struct ynode *bn = seq->kids[i];

		b->line = bn->line;
		path_idx(path, "buses", i);
		if (bn->kind != Y_MAP)
			continue;
		for (unsigned j = 0; j < i; j++) {
			if (b->name[0] && !strcmp(cfg->buses[j].name, b->name)) {
				path_key(kp, path, "name");
				report(c, line_of(bn, "name"), kp,
				       "\"%s\" is already the name of buses[%u] (line %u)", b->name,
				       j, cfg->buses[j].line);
				break;
			}
		}
		if (c->bad_bus & (1u << i))
			continue;
		switch (b->kind) {
		case RMD_BUS_KIND_SOCKETCAN:
			bus_key_unused(c, bn, path, "device", b, "rs485");
			bus_key_unused(c, bn, path, "baud", b, "rs485");
			bus_key_unused(c, bn, path, "turnaround_us", b, "rs485");
			bus_key_unused(c, bn, path, "sim", b, "sim");
			path_key(kp, path, "interface");
			if (!map_get(bn, "interface", NULL)) {
				if (strlen(b->name) >= sizeof(b->interface))
					report(c, bn->line, kp,
					       "required: the name \"%s\" is too long for an "
					       "interface name (at most %zu characters)",
					       b->name, sizeof(b->interface) - 1);
				else
					memcpy(b->interface, b->name, strlen(b->name) + 1);
			} else if (!b->interface[0] || strpbrk(b->interface, "/: \t") ||
				   !strcmp(b->interface, ".") || !strcmp(b->interface, "..")) {
				report(c, line_of(bn, "interface"), kp,
				       "\"%s\" is not a network interface name", b->interface);
			}
			if (!uint_in(b->bitrate, can_rates, 2)) {
				path_key(kp, path, "bitrate");
				report(c, line_of(bn, "bitrate"), kp,
				       "%u is not a bitrate RMD motors speak (V3 §2.31: 500000 or "
				       "1000000)",
				       b->bitrate);
			}
			break;
		case RMD_BUS_KIND_RS485:
			bus_key_unused(c, bn, path, "interface", b, "socketcan");
			bus_key_unused(c, bn, path, "bitrate", b, "socketcan or sim");
			bus_key_unused(c, bn, path, "sim", b, "sim");
			path_key(kp, path, "device");
			if (!map_get(bn, "device", NULL))
				report(c, bn->line, kp,
				       "required for type rs485 (e.g. /dev/ttyUSB0)");
			else if (b->device[0] != '/')
				report(c, line_of(bn, "device"), kp,
				       "\"%s\" is not a device path (e.g. /dev/ttyUSB0)",
				       b->device);
			if (rmd_rs485_baud_speed(b->baud, NULL) < 0) {
				path_key(kp, path, "baud");
				report(c, line_of(bn, "baud"), kp,
				       "%u is not a baud rate RMD motors speak (V3 §1.2.1: 115200, "
				       "500000, 1000000, 1500000, 2000000)",
				       b->baud);
			}
			break;
		case RMD_BUS_KIND_SIM: {
			const struct ynode *sn = map_get(bn, "sim", NULL);

			bus_key_unused(c, bn, path, "interface", b, "socketcan");
			bus_key_unused(c, bn, path, "device", b, "rs485");
			bus_key_unused(c, bn, path, "baud", b, "rs485");
			bus_key_unused(c, bn, path, "turnaround_us", b, "rs485");
			if (b->bitrate < 10000 || b->bitrate > 1000000) {
				path_key(kp, path, "bitrate");
				report(c, line_of(bn, "bitrate"), kp,
				       "%u is out of range (10000..1000000 for a sim bus)",
				       b->bitrate);
			}
			path_key(kp, path, "sim.motor");
			validate_sim_model(c, &b->sim.motor, map_get(sn, "motor", NULL), kp);
			break;
		}
		}
	}
}

/* The fault entries of sim bus i, once its motors are known. */
static void validate_faults(struct ctx *c, const struct rmd_config *cfg, unsigned bi,
			    const struct ynode *bn)
{
	const struct rmd_config_bus *b = &cfg->buses[bi];
	const struct ynode *faults = map_get(map_get(bn, "sim", NULL), "faults", NULL);
	char path[PATH_LEN], kp[PATH_LEN];

	for (unsigned i = 0; i < b->sim.n_faults && faults && faults->kind == Y_SEQ; i++) {
		const struct rmd_sim_fault *f = &b->sim.faults[i];
		const struct ynode *fn = faults->kids[i];
		const char *kind = fault_names[f->kind];
		bool bus_wide = f->kind == RMD_SIM_FAULT_BUS_OFF || f->kind == RMD_SIM_FAULT_FLOOD;
		bool found = false;
		int64_t lo = 0, hi = 0;
		const char *what = NULL;

		snprintf(path, sizeof(path), "buses[%u].sim.faults[%u]", bi, i);
		if (bus_wide && f->motor_id) {
			path_key(kp, path, "motor");
			report(c, line_of(fn, "motor"), kp,
			       "%s acts on the whole bus: leave motor out (or 0)", kind);
		}
		for (unsigned m = 0; m < cfg->n_motors && f->motor_id; m++)
			if (cfg->motors[m].bus == bi && cfg->motors[m].id == f->motor_id)
				found = true;
		if (f->motor_id && !found && !bus_wide) {
			path_key(kp, path, "motor");
			report(c, line_of(fn, "motor"), kp, "no motor with id %u on bus %s",
			       f->motor_id, b->name);
		}
		if (f->end_ns && f->end_ns <= f->start_ns) {
			path_key(kp, path, "end_s");
			report(c, line_of(fn, "end_s"), kp,
			       "must be after start_s, or 0 to leave the window open");
		}
		switch (f->kind) {
		case RMD_SIM_FAULT_DROP:
		case RMD_SIM_FAULT_GARBAGE:
		case RMD_SIM_FAULT_BUS_OFF:
		case RMD_SIM_FAULT_COUNT:
			break;
		case RMD_SIM_FAULT_DELAY:
			lo = 0, hi = INT64_C(10000000000), what = "the delay in ns";
			break;
		case RMD_SIM_FAULT_BAD_DLC:
			lo = 0, hi = 7, what = "the DLC";
			break;
		case RMD_SIM_FAULT_WRONG_ID:
			lo = 1, hi = RMD_MAX_MOTORS, what = "the motor id whose identifier is used";
			break;
		case RMD_SIM_FAULT_DISAPPEAR:
			lo = 0, hi = 1, what = "1 when the motor loses power";
			break;
		case RMD_SIM_FAULT_ERROR_FLAG:
			lo = 1, hi = 0xFFFF, what = "the error bits (V3 §2.12)";
			break;
		case RMD_SIM_FAULT_FLOOD:
			lo = 1, hi = INT64_C(10000000000), what = "the interval in ns";
			break;
		}
		if (what && (f->param < lo || f->param > hi)) {
			path_key(kp, path, "param");
			report(c, line_of(fn, "param"), kp,
			       "%lld is out of range for %s (%lld..%lld: %s)", (long long)f->param,
			       kind, (long long)lo, (long long)hi, what);
		}
		if (f->kind != RMD_SIM_FAULT_FLOOD && map_get(fn, "can_id", NULL)) {
			path_key(kp, path, "can_id");
			report(c, line_of(fn, "can_id"), kp, "only for kind flood");
		}
	}
}

static void validate_motor_sim(struct ctx *c, struct rmd_config *cfg, unsigned i,
			       const struct ynode *mn, const char *path)
{
	struct rmd_config_motor *m = &cfg->motors[i];
	const struct rmd_config_bus *b = &cfg->buses[m->bus];
	const struct ynode *sn = map_get(mn, "sim", NULL);
	char kp[PATH_LEN];

	path_key(kp, path, "sim");
	if (sn && b->kind != RMD_BUS_KIND_SIM) {
		report(c, line_of(mn, "sim"), kp, "only for motors on a sim bus (%s is %s)",
		       b->name, rmd_bus_kind_name(b->kind));
		return;
	}
	m->sim = b->sim.motor;
	if (sn) {
		struct field f = { .type = T_MAP, .sub = sim_motor_fields };

		walk_value(c, sn, &f, &m->sim, kp);
		validate_sim_model(c, &m->sim, sn, kp);
	}
	m->sim.id = m->id;
	m->sim.proto = m->proto;
	m->sim.mit = m->mit;
	if (map_get(mn, "gear_ratio", NULL))
		m->sim.gear_ratio = m->gear_ratio;
	if (m->torque_constant_nm_a > 0)
		m->sim.kt_nm_a = m->torque_constant_nm_a;
}

static void validate_mit(struct ctx *c, const struct rmd_mit_ranges *r, const struct ynode *n,
			 const char *path)
{
	static const struct {
		const char *lo, *hi;
		size_t lo_off, hi_off;
	} pairs[] = {
#define PAIR(a, b) \
	{ #a, #b, offsetof(struct rmd_mit_ranges, a), offsetof(struct rmd_mit_ranges, b) }
		PAIR(p_min, p_max),   PAIR(v_min, v_max),   PAIR(t_min, t_max),
		PAIR(kp_min, kp_max), PAIR(kd_min, kd_max),
#undef PAIR
	};
	char kp[PATH_LEN];

	for (size_t i = 0; i < sizeof(pairs) / sizeof(pairs[0]); i++) {
		double lo, hi;

		memcpy(&lo, (const char *)r + pairs[i].lo_off, sizeof(lo));
		memcpy(&hi, (const char *)r + pairs[i].hi_off, sizeof(hi));
		if (!(lo < hi)) {
			path_key(kp, path, pairs[i].lo);
			report(c, line_of(n, pairs[i].lo), kp, "%g must be below %s (%g)", lo,
			       pairs[i].hi, hi);
		}
	}
}

static void validate_motors(struct ctx *c, struct rmd_config *cfg, const struct ynode *seq)
{
	char path[PATH_LEN], kp[PATH_LEN], names[RMD_MAX_BUSES * (RMD_CONFIG_NAME_LEN + 2)];
	const unsigned rate = cfg->loop.rate_hz;

	names[0] = '\0';
	for (unsigned i = 0, k = 0; i < cfg->n_buses; i++)
		if (cfg->buses[i].name[0])
			k += (unsigned)snprintf(names + k, sizeof(names) - k, "%s%s", k ? ", " : "",
						cfg->buses[i].name);
	for (unsigned i = 0; i < cfg->n_motors; i++) {
		struct rmd_config_motor *m = &cfg->motors[i];
		const struct ynode *mn = seq->kids[i], *bv;
		unsigned bl = 0;
		int bi = -1;

		m->line = mn->line;
		path_idx(path, "motors", i);
		if (mn->kind != Y_MAP)
			continue;
		for (unsigned j = 0; j < i; j++) {
			if (m->name[0] && !strcmp(cfg->motors[j].name, m->name)) {
				path_key(kp, path, "name");
				report(c, line_of(mn, "name"), kp,
				       "\"%s\" is already the name of motors[%u] (line %u)",
				       m->name, j, cfg->motors[j].line);
				break;
			}
		}
		/* bus */
		path_key(kp, path, "bus");
		bv = map_get(mn, "bus", &bl);
		if (!bv) {
			report(c, mn->line, kp, "required key missing (buses: %s)", names);
		} else if (bv->kind != Y_SCALAR || is_null(bv)) {
			report(c, bv->line, kp, "expected the name of a bus (%s)", names);
		} else {
			bi = rmd_config_bus_find(cfg, bv->str);
			if (bi < 0)
				report(c, bv->line, kp, "\"%s\" is not a bus; buses: %s", bv->str,
				       cfg->n_buses ? names : "none");
		}
		if (bi < 0) {
			m->bus = RMD_MAX_BUSES; /* unresolved */
			continue;
		}
		m->bus = (unsigned)bi;
		if ((c->bad_motor & (1u << i)) || (c->bad_bus & (1u << bi)))
			continue;
		/* id unique per bus */
		for (unsigned j = 0; j < i; j++) {
			const struct rmd_config_motor *o = &cfg->motors[j];

			if (o->bus == m->bus && o->id == m->id && m->id) {
				path_key(kp, path, "id");
				report(c, line_of(mn, "id"), kp,
				       "%u is already the id of motors[%u] (%s, line %u) on bus %s",
				       m->id, j, o->name, line_of(seq->kids[j], "id"),
				       cfg->buses[bi].name);
				break;
			}
		}
		/* protocol and mode */
		if (m->proto == RMD_PROTO_MIT && m->mode != RMD_CTRL_MIT) {
			path_key(kp, path, "mode");
			report(c, line_of(mn, "mode"), kp,
			       "%s: a mit protocol motor runs in mode mit (V3 §5)",
			       rmd_ctrl_mode_name(m->mode));
		} else if (m->mode == RMD_CTRL_MIT && m->proto != RMD_PROTO_MIT) {
			path_key(kp, path, "mode");
			report(c, line_of(mn, "mode"), kp,
			       "mit needs protocol mit (this motor is %s)",
			       rmd_proto_key(m->proto));
		}
		if (cfg->buses[bi].kind == RMD_BUS_KIND_RS485 && m->proto != RMD_PROTO_V3) {
			path_key(kp, path, "protocol");
			report(c, line_of(mn, "protocol"), kp,
			       "%s has no RS485 form (V3 §1.2: RS485 carries v3 frames); bus %s is "
			       "rs485",
			       rmd_proto_key(m->proto), cfg->buses[bi].name);
		}
		if (m->proto != RMD_PROTO_MIT && !(m->torque_constant_nm_a > 0)) {
			path_key(kp, path, "torque_constant_nm_a");
			report(c, mn->line, kp,
			       "required for protocol %s: its frames carry current (0.01 A), "
			       "which rmdd converts to N·m",
			       rmd_proto_key(m->proto));
		}
		/* limits */
		if (!(m->limits.position_min_rad < m->limits.position_max_rad)) {
			const struct ynode *ln = map_get(mn, "limits", NULL);

			path_key(kp, path, "limits.position_min_rad");
			report(c, line_of(ln, "position_min_rad"), kp,
			       "%g must be below position_max_rad (%g)", m->limits.position_min_rad,
			       m->limits.position_max_rad);
		}
		path_key(kp, path, "mit");
		validate_mit(c, &m->mit, map_get(mn, "mit", NULL), kp);
		/* rates */
		if (m->status_poll_hz > (double)rate / m->rate_divisor) {
			path_key(kp, path, "status_poll_hz");
			report(c, line_of(mn, "status_poll_hz"), kp,
			       "%g is more than the motor's command rate (%g Hz: rate_hz %u / "
			       "rate_divisor %u)",
			       m->status_poll_hz, (double)rate / m->rate_divisor, rate,
			       m->rate_divisor);
		}
		validate_motor_sim(c, cfg, i, mn, path);
	}
}

static void validate_lcm(struct ctx *c, const struct rmd_config *cfg, const struct ynode *root)
{
	const struct ynode *ln = map_get(root, "lcm", NULL);
	const char *p = cfg->lcm.channel_prefix;
	const char *scheme = strstr(cfg->lcm.url, "://");

	if (!scheme || scheme == cfg->lcm.url)
		report(c, line_of(ln, "url"), "lcm.url",
		       "\"%s\" is not an LCM provider URL (e.g. udpm://239.255.76.67:7667?ttl=0, "
		       "memq://)",
		       cfg->lcm.url);
	if (strspn(p, "ABCDEFGHIJKLMNOPQRSTUVWXYZabcdefghijklmnopqrstuvwxyz0123456789_.-/") !=
	    strlen(p))
		report(c, line_of(ln, "channel_prefix"), "lcm.channel_prefix",
		       "\"%s\": use letters, digits and _ . - / only", p);
}

/* Timeouts against the loop and the motors' command periods. */
static void validate_timing(struct ctx *c, const struct rmd_config *cfg, const struct ynode *root)
{
	const struct ynode *sn = map_get(root, "safety", NULL);
	const struct rmd_config_safety *s = &cfg->safety;
	const unsigned rate = cfg->loop.rate_hz;
	double cycle_ms = 1000.0 / rate;

	if ((double)s->command_timeout_ms < 2.0 * cycle_ms)
		report(c, line_of(sn, "command_timeout_ms"), "safety.command_timeout_ms",
		       "%u ms is shorter than two cycles (%g ms at %u Hz)", s->command_timeout_ms,
		       2.0 * cycle_ms, rate);
	if (s->comm_loss_ms == 0)
		return;
	for (unsigned i = 0; i < cfg->n_motors; i++) {
		const struct rmd_config_motor *m = &cfg->motors[i];
		double need_ms = 5.0 * cycle_ms * m->rate_divisor;

		if ((double)s->comm_loss_ms < need_ms) {
			report(c, line_of(sn, "comm_loss_ms"), "safety.comm_loss_ms",
			       "%u ms is shorter than 5 command periods of motor %s (%g ms): its "
			       "own protection would trip in normal operation; use >= %.0f, or 0 "
			       "(off)",
			       s->comm_loss_ms, m->name, need_ms, ceil(need_ms));
			return;
		}
	}
}

/* ------------------------------------------------------------------ */
/* API */

void rmd_config_defaults(struct rmd_config *cfg)
{
	memset(cfg, 0, sizeof(*cfg));
	cfg->loop.rate_hz = RMD_CONFIG_DEFAULT_RATE_HZ;
	cfg->loop.rt_priority = RMD_CONFIG_DEFAULT_PRIORITY;
	cfg->safety.comm_loss_ms = RMD_CONFIG_DEFAULT_COMM_LOSS_MS;
	cfg->safety.missed_replies_lost = RMD_CONFIG_DEFAULT_MISSED_LOST;
	cfg->safety.command_timeout_ms = RMD_CONFIG_DEFAULT_COMMAND_TIMEOUT_MS;
	cfg->safety.safe_action = RMD_SAFE_DAMP;
	cfg->safety.lost_motor_action = RMD_LOST_ALL;
	cfg->probe.on_missing = RMD_MISSING_REFUSE;
	snprintf(cfg->lcm.url, sizeof(cfg->lcm.url), "%s", RMD_CONFIG_DEFAULT_LCM_URL);
	snprintf(cfg->lcm.channel_prefix, sizeof(cfg->lcm.channel_prefix), "%s",
		 RMD_CONFIG_DEFAULT_CHANNEL_PREFIX);
	cfg->lcm.state_every_n = 1;
	cfg->lcm.stale_ms = RMD_CONFIG_DEFAULT_STALE_MS;
	cfg->lcm.health_period_ms = RMD_CONFIG_DEFAULT_HEALTH_PERIOD_MS;
}

int rmd_config_load(const char *path, struct rmd_config *cfg, char *err, size_t errlen)
{
	struct ctx c = { .file = path, .err = err, .errlen = errlen };
	struct ytree t = { 0 };
	const struct ynode *root;
	FILE *f;
	int ret;

	if (err && errlen)
		err[0] = '\0';
	rmd_config_defaults(cfg);
	snprintf(cfg->source, sizeof(cfg->source), "%s", path);
	f = fopen(path, "r");
	if (!f) {
		ret = -errno;
		report(&c, 0, "", "cannot open: %s", strerror(-ret));
		return ret;
	}
	ret = tree_load(&c, f, &t);
	fclose(f);
	if (ret == -ENOMEM)
		report(&c, 0, "", "out of memory");
	if (ret)
		goto out;
	root = t.root;
	if (!root || is_null(root)) {
		report(&c, 1, "buses, motors", "required keys missing (the file is empty)");
		ret = -EINVAL;
		goto out;
	}
	if (root->kind != Y_MAP) {
		char names[256];

		join_names(names, sizeof(names), NULL, top_fields);
		report(&c, root->line, "(top level)", "expected a mapping of %s, got %s", names,
		       kind_desc(root));
		ret = -EINVAL;
		goto out;
	}
	walk_map(&c, root, top_fields, cfg, "");
	if (!map_get(root, "buses", NULL))
		report(&c, root->line, "buses", "required key missing");
	if (!map_get(root, "motors", NULL))
		report(&c, root->line, "motors", "required key missing");
	if (cfg->n_buses == 0 && map_get(root, "buses", NULL))
		report(&c, line_of(root, "buses"), "buses", "at least one bus is required");
	if (cfg->n_motors == 0 && map_get(root, "motors", NULL))
		report(&c, line_of(root, "motors"), "motors", "at least one motor is required");
	{
		const struct ynode *bs = map_get(root, "buses", NULL);
		const struct ynode *ms = map_get(root, "motors", NULL);

		if (bs && bs->kind == Y_SEQ)
			validate_buses(&c, cfg, bs);
		if (ms && ms->kind == Y_SEQ)
			validate_motors(&c, cfg, ms);
		for (unsigned i = 0; bs && bs->kind == Y_SEQ && i < cfg->n_buses; i++)
			if (cfg->buses[i].kind == RMD_BUS_KIND_SIM && !(c.bad_bus & (1u << i)))
				validate_faults(&c, cfg, i, bs->kids[i]);
	}
	validate_lcm(&c, cfg, root);
	validate_timing(&c, cfg, root);
	ret = c.nerr ? -EINVAL : 0;
out:
	tree_free(&t);
	return ret;
}

int rmd_config_sim_default(struct rmd_config *cfg, unsigned nmotors)
{
	const unsigned per_bus = 3; /* DESIGN.md: 3 motors per 1 Mbit/s bus at 1 kHz */

	if (nmotors < 1 || nmotors > RMD_MAX_MOTORS)
		return -EINVAL;
	rmd_config_defaults(cfg);
	snprintf(cfg->source, sizeof(cfg->source), "(built-in sim)");
	cfg->n_buses = (nmotors + per_bus - 1) / per_bus;
	for (unsigned b = 0; b < cfg->n_buses; b++) {
		struct rmd_config_bus *bus = &cfg->buses[b];

		bus_init(bus);
		snprintf(bus->name, sizeof(bus->name), "sim%u", b);
		bus->kind = RMD_BUS_KIND_SIM;
		bus->sim.seed = b + 1;
	}
	cfg->n_motors = nmotors;
	for (unsigned i = 0; i < nmotors; i++) {
		struct rmd_config_motor *m = &cfg->motors[i];
		const struct rmd_config_bus *bus;

		motor_init(m);
		snprintf(m->name, sizeof(m->name), "motor%u", i + 1);
		m->bus = i / per_bus;
		m->id = (uint8_t)(i % per_bus + 1);
		bus = &cfg->buses[m->bus];
		m->gear_ratio = bus->sim.motor.gear_ratio;
		m->torque_constant_nm_a = bus->sim.motor.kt_nm_a;
		m->limits.velocity_rad_s = 20.0;
		m->limits.torque_nm = 10.0;
		m->sim = bus->sim.motor;
		m->sim.id = m->id;
		m->sim.proto = m->proto;
	}
	return 0;
}

int rmd_config_bus_find(const struct rmd_config *cfg, const char *name)
{
	for (unsigned i = 0; i < cfg->n_buses; i++)
		if (!strcmp(cfg->buses[i].name, name))
			return (int)i;
	return -ENOENT;
}

int rmd_config_motor_find(const struct rmd_config *cfg, const char *name)
{
	for (unsigned i = 0; i < cfg->n_motors; i++)
		if (!strcmp(cfg->motors[i].name, name))
			return (int)i;
	return -ENOENT;
}

const char *rmd_bus_kind_name(enum rmd_bus_kind kind)
{
	return (unsigned)kind < 3 ? bus_kind_names[kind] : "?";
}

const char *rmd_ctrl_mode_name(enum rmd_ctrl_mode mode)
{
	return (unsigned)mode < 4 ? mode_names[mode] : "?";
}

const char *rmd_safe_action_name(enum rmd_safe_action action)
{
	return (unsigned)action < 4 ? safe_names[action] : "?";
}

int rmd_config_open_sim_bus(const struct rmd_config *cfg, unsigned b, struct rmd_bus *bus,
			    char *err, size_t errlen)
{
	const struct rmd_config_bus *cb = &cfg->buses[b];
	struct rmd_bus_sim_motor motors[RMD_MAX_MOTORS];
	struct rmd_bus_sim_opts o = {
		.motors = motors,
		.bitrate = cb->bitrate,
		.seed = cb->sim.seed,
		.flags = cb->sim.host_fifo ? RMD_SIM_BUS_HOST_FIFO : 0,
		.txqueuelen = cb->sim.txqueuelen,
		.faults = cb->sim.faults,
		.n_faults = cb->sim.n_faults,
	};

	if (b >= cfg->n_buses || cb->kind != RMD_BUS_KIND_SIM)
		return rmd_errf(err, errlen, -EINVAL, "bus %u is not a sim bus", b);
	for (unsigned i = 0; i < cfg->n_motors; i++) {
		const struct rmd_config_motor *m = &cfg->motors[i];

		if (m->bus != b || o.n_motors >= RMD_MAX_MOTORS)
			continue;
		motors[o.n_motors++] = (struct rmd_bus_sim_motor){ .id = m->id,
								   .proto = m->proto,
								   .params = &m->sim };
	}
	return rmd_bus_sim_open(bus, cb->name, &o, err, errlen);
}
