// SPDX-License-Identifier: MIT
/*
 * rmd-sim configuration: the settings the command line and the config file
 * share, their validation, and the fault syntax.  One table lists every
 * motor parameter with its range and unit; the same table drives the long
 * options (rmd-sim.c), the config file keys and --help, so a parameter is
 * added in exactly one place.
 *
 * Settings are recorded in the order given and replayed onto each motor's
 * struct rmd_sim_motor_params by sim_config_finish(): every global setting
 * first, then the motor's own ([motor N] sections, --set N:KEY=VALUE), so
 * a per-motor value wins over a global one wherever each came from.  They
 * start from the defaults, or from the motor of an rmdd.yaml
 * (sim_config_yaml(), rmdd's own loader), which they all override.
 *
 * Non-rt.
 */
#include <ctype.h>
#include <errno.h>
#include <math.h>
#include <net/if.h>
#include <stdarg.h>
#include <stddef.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "rmd/codec.h"
#include "rmd/config.h"
#include "rmd/config_yaml.h"
#include "rmd/dialect.h"
#include "rmd/mit.h"
#include "rmd/personality_load.h"
#include "rmd/rs485.h"
#include "rmd/sim.h"
#include "rmd/sim_params.h"
#include "rmd/sim_wire.h"
#include "rmd-sim.h"

#define ARRAY_SIZE(a) (sizeof(a) / sizeof((a)[0]))

#define BAUD_LIST "115200, 500000, 1000000, 1500000 or 2000000 (V3 §1.2.1)"

/* Fault times and delays: seconds and microseconds, bounded to keep int64 ns far from overflow. */
#define MAX_TIME_S 1e6
#define MAX_DELAY_US 1e7

/* -------------------------------------------------------------------------- */
/* Settings                                                                   */

/*
 * The motor parameters are the rows of rmd/sim_params.h, which rmdd.yaml's
 * sim sections read too.  Settings that apply to the whole program, not to
 * one motor:
 */
static const struct {
	const char *key;
	const char *arg;
	const char *help;
} globals[] = {
	{ "can", "IFACE", "SocketCAN interface to answer on (e.g. vcan0)" },
	{ "serial", "DEVICE", "RS485 serial device to answer on (e.g. /dev/ttyUSB0)" },
	{ "baud", "B", "serial rate: " BAUD_LIST "; default 1000000, as rmdd and rmdctl" },
	{ "local-echo", "",
	  "serial: the adapter hears its own replies; drop them (config: yes/no)" },
	{ "motors", "LIST", "motor ids, e.g. 1-4,7 (default 1)" },
	{ "fault", "SPEC", "inject a fault, repeatable (see FAULTS)" },
	{ "seed", "N", "seed of every random choice (jitter, faults); default 1" },
	{ "verbosity", "LEVEL", "quiet, normal or frames (as -q, default, -v)" },
};

static bool is_global(const char *key)
{
	for (size_t i = 0; i < ARRAY_SIZE(globals); i++)
		if (!strcmp(globals[i].key, key))
			return true;
	return false;
}

/*
 * The long options of the motor parameters: each row's canonical name as
 * rmdd.yaml spells it, the same with '-' for '_', and its alias.
 */
#define PARAM_NAMES 3
static char param_dashed[64][SIM_KEY_MAX];

static const char *param_name(unsigned row, unsigned which)
{
	const struct rmd_sim_param *p = &rmd_sim_params[row];
	char *d = param_dashed[row];

	switch (which) {
	case 0:
		return p->key;
	case 1:
		if (!strchr(p->key, '_') || row >= ARRAY_SIZE(param_dashed))
			return NULL;
		for (size_t k = 0; k < SIM_KEY_MAX - 1 && p->key[k]; k++)
			d[k] = p->key[k] == '_' ? '-' : p->key[k];
		return d;
	default:
		return p->alias;
	}
}

const char *sim_config_key(unsigned i, bool *is_flag)
{
	if (i < ARRAY_SIZE(globals)) {
		*is_flag = !strcmp(globals[i].key, "local-echo");
		return globals[i].key;
	}
	i -= (unsigned)ARRAY_SIZE(globals);
	*is_flag = false;
	if (i >= rmd_sim_n_params * PARAM_NAMES)
		return NULL;
	/* "": this row has no such name (main() skips it) */
	return param_name(i / PARAM_NAMES, i % PARAM_NAMES) ?: "";
}

bool sim_config_key_listed(unsigned i)
{
	return i < ARRAY_SIZE(globals) || (i - ARRAY_SIZE(globals)) % PARAM_NAMES == 0;
}

void sim_config_help(void)
{
	printf("Wire and program:\n");
	for (size_t i = 0; i < ARRAY_SIZE(globals); i++)
		printf("  --%s%s%s\n      %s\n", globals[i].key, *globals[i].arg ? " " : "",
		       globals[i].arg, globals[i].help);
	printf("\nMotor parameters (for every motor; per motor in a [motor N] section or with\n"
	       "--set N:KEY=VALUE).  The names are those of rmdd.yaml's sim sections, with the\n"
	       "unit in the name; '-' and '_' alike.  rmd-sim's older names stay as aliases\n"
	       "with the same meaning:\n");
	for (size_t i = 0; i < rmd_sim_n_params; i++) {
		const struct rmd_sim_param *p = &rmd_sim_params[i];

		printf("  --%s VALUE", p->key);
		if (p->alias)
			printf("  (alias: --%s)", p->alias);
		printf("\n      ");
		if (p->flags & RMD_SIM_PARAM_KEYS_FIRST) {
			char keys[64];

			printf("%s ", rmd_proto_keys_text(keys, sizeof(keys), ", ", " or "));
		}
		printf("%s", p->help);
		if (p->type == RMD_SIM_PARAM_REAL || p->type == RMD_SIM_PARAM_US ||
		    p->type == RMD_SIM_PARAM_UINT)
			printf(", %s%g..%g", p->min_excl ? ">" : "", p->min, p->max);
		if (*p->unit)
			printf(" %s", p->unit);
		printf("\n");
	}
}

/* "1-4,7": ids 1..32, ascending ranges. */
static int parse_motors(const char *s, uint32_t *mask)
{
	uint32_t m = 0;
	const char *p = s;

	if (!*p)
		return -EINVAL;
	for (;;) {
		char *end;
		unsigned long a, b;

		if (!isdigit((unsigned char)*p))
			return -EINVAL;
		a = strtoul(p, &end, 10);
		b = a;
		if (*end == '-') {
			p = end + 1;
			if (!isdigit((unsigned char)*p))
				return -EINVAL;
			b = strtoul(p, &end, 10);
		}
		if (a < 1 || b > RMD_MAX_MOTORS || a > b)
			return -EINVAL;
		for (unsigned long i = a; i <= b; i++)
			m |= UINT32_C(1) << (i - 1);
		if (*end == '\0')
			break;
		if (*end != ',')
			return -EINVAL;
		p = end + 1;
	}
	*mask = m;
	return 0;
}

void sim_format_motors(uint32_t mask, char *buf, size_t size)
{
	size_t n = 0;

	buf[0] = '\0';
	for (unsigned i = 0; i < RMD_MAX_MOTORS && n < size; i++) {
		unsigned j = i;

		if (!(mask & (UINT32_C(1) << i)))
			continue;
		while (j + 1 < RMD_MAX_MOTORS && (mask & (UINT32_C(1) << (j + 1))))
			j++;
		if (j > i)
			n += (size_t)snprintf(buf + n, size - n, "%s%u-%u", n ? "," : "", i + 1,
					      j + 1);
		else
			n += (size_t)snprintf(buf + n, size - n, "%s%u", n ? "," : "", i + 1);
		i = j;
	}
}

/* -------------------------------------------------------------------------- */
/* Faults                                                                     */

#define FAULT_SYNTAX                                                                     \
	"drop:ID:P, delay:ID:US:P, bad_dlc:ID:DLC:P, garbage:ID:P, wrong_id:ID:OTHER:P " \
	"(each with an optional /CMD[,COUNT] filter and @START_S-END_S window), "        \
	"disappear:ID:START_S:END_S[:reboot], "                                          \
	"error_flag:ID:BITS:AT_S[:END_S], flood:CANID:PERIOD_US:START_S[:END_S], "       \
	"bus_power:START_S:END_S"

struct fault_syntax {
	enum rmd_sim_fault_kind kind;
	const char *syntax;
};

static const struct fault_syntax fault_syntaxes[] = {
	{ RMD_SIM_FAULT_DROP, "drop:ID:P[/CMD[,COUNT]][@START_S-END_S]" },
	{ RMD_SIM_FAULT_DELAY, "delay:ID:US:P[/CMD[,COUNT]][@START_S-END_S]" },
	{ RMD_SIM_FAULT_BAD_DLC, "bad_dlc:ID:DLC:P[/CMD[,COUNT]][@START_S-END_S]" },
	{ RMD_SIM_FAULT_GARBAGE, "garbage:ID:P[/CMD[,COUNT]][@START_S-END_S]" },
	{ RMD_SIM_FAULT_WRONG_ID, "wrong_id:ID:OTHER_ID:P[/CMD[,COUNT]][@START_S-END_S]" },
	{ RMD_SIM_FAULT_DISAPPEAR, "disappear:ID:START_S:END_S[:reboot]" },
	{ RMD_SIM_FAULT_ERROR_FLAG, "error_flag:ID:BITS:AT_S[:END_S]" },
	{ RMD_SIM_FAULT_FLOOD, "flood:CANID:PERIOD_US:START_S[:END_S]" },
	{ RMD_SIM_FAULT_BUS_POWER, "bus_power:START_S:END_S" },
};

static const char *fault_syntax(enum rmd_sim_fault_kind kind)
{
	for (size_t i = 0; i < ARRAY_SIZE(fault_syntaxes); i++)
		if (fault_syntaxes[i].kind == kind)
			return fault_syntaxes[i].syntax;
	return FAULT_SYNTAX;
}

/* A time in seconds, 0..MAX_TIME_S, to ns. */
static int parse_seconds(const char *s, int64_t *ns)
{
	double v;

	if (rmd_sim_parse_real(s, &v) < 0 || v < 0 || v > MAX_TIME_S)
		return -EINVAL;
	*ns = (int64_t)llround(v * 1e9);
	return 0;
}

static int parse_probability(const char *s, double *p)
{
	if (rmd_sim_parse_real(s, p) < 0 || *p < 0 || *p > 1)
		return -EINVAL;
	return 0;
}

/* "*" or 0: every motor; else 1..32. */
static int parse_fault_motor(const char *s, uint8_t *id)
{
	uint64_t v;

	if (!strcmp(s, "*")) {
		*id = 0;
		return 0;
	}
	if (rmd_sim_parse_u64(s, &v) < 0 || v > RMD_MAX_MOTORS)
		return -EINVAL;
	*id = (uint8_t)v;
	return 0;
}

/* Error bits: a number 1..0xFFFF, or V3 §2.12 table 1 names joined by '+'. */
static int parse_error_bits(const char *s, int64_t *bits)
{
	uint64_t v;
	char buf[SIM_VALUE_MAX];
	char *save = NULL, *tok;
	uint32_t acc = 0;

	if (rmd_sim_parse_u64(s, &v) == 0) {
		if (v < 1 || v > 0xFFFF)
			return -EINVAL;
		*bits = (int64_t)v;
		return 0;
	}
	if (strlen(s) >= sizeof(buf))
		return -EINVAL;
	strcpy(buf, s);
	for (tok = strtok_r(buf, "+", &save); tok; tok = strtok_r(NULL, "+", &save)) {
		bool found = false;

		for (unsigned b = 0; b < 16 && !found; b++) {
			const char *name = NULL;

			if (rmd_error_names(RMD_PROTO_V3, (uint16_t)(1u << b), &name, 1) == 1 &&
			    name && strncmp(name, "unknown", 7) && !strcmp(name, tok)) {
				acc |= 1u << b;
				found = true;
			}
		}
		if (!found)
			return -EINVAL;
	}
	if (!acc)
		return -EINVAL;
	*bits = acc;
	return 0;
}

static void error_bit_names(char *buf, size_t size)
{
	size_t n = 0;

	buf[0] = '\0';
	for (unsigned b = 0; b < 16 && n < size; b++) {
		const char *name = NULL;

		if (rmd_error_names(RMD_PROTO_V3, (uint16_t)(1u << b), &name, 1) == 1 && name &&
		    strncmp(name, "unknown", 7))
			n += (size_t)snprintf(buf + n, size - n, "%s%s", n ? ", " : "", name);
	}
}

#define MAX_FAULT_FIELDS 6

static int fault_error(const char *where, const char *spec, const char *what,
		       enum rmd_sim_fault_kind kind)
{
	tool_log(TOOL_LOG_ERR, "rmd-sim: %s \"%s\": %s; syntax %s", where, spec, what,
		 fault_syntax(kind));
	return -EINVAL;
}

/* "CMD[,COUNT]": only frames whose first byte is CMD, at most COUNT of them (rmd/sim_faults.h). */
static int parse_fault_filter(char *s, struct rmd_sim_fault *f)
{
	char *comma = strchr(s, ',');
	uint64_t v;

	if (comma)
		*comma++ = '\0';
	if (rmd_sim_parse_u64(s, &v) < 0 || v < 1 || v > 0xFF)
		return -EINVAL;
	f->cmd = (uint8_t)v;
	if (!comma)
		return 0;
	if (rmd_sim_parse_u64(comma, &v) < 0 || v < 1 || v > UINT32_MAX)
		return -EINVAL;
	f->count = (uint32_t)v;
	return 0;
}

/*
 * A fault's time fields: `start` (named start_name in the message) and
 * `end`, which may be NULL or empty (never).  Returns 0 or -EINVAL, logged.
 */
static int parse_fault_times(const char *where, const char *spec, struct rmd_sim_fault *f,
			     const char *start_name, const char *start, const char *end)
{
	char what[64];

	if (parse_seconds(start, &f->start_ns) < 0) {
		snprintf(what, sizeof(what), "%s must be 0..1e6 s", start_name);
		return fault_error(where, spec, what, f->kind);
	}
	if (end && *end && parse_seconds(end, &f->end_ns) < 0)
		return fault_error(where, spec, "END_S must be empty (never) or 0..1e6 s", f->kind);
	return 0;
}

static int parse_fault(struct sim_config *c, const char *spec, const char *where)
{
	char buf[SIM_VALUE_MAX], *fld[MAX_FAULT_FIELDS], *window, *filter, *p;
	struct rmd_sim_fault f;
	unsigned n = 0;
	int kind;
	bool per_frame;

	if (strlen(spec) >= sizeof(buf)) {
		tool_log(TOOL_LOG_ERR, "rmd-sim: %s: fault longer than %zu characters", where,
			 sizeof(buf) - 1);
		return -EINVAL;
	}
	strcpy(buf, spec);
	window = strchr(buf, '@');
	if (window)
		*window++ = '\0';
	filter = strchr(buf, '/');
	if (filter)
		*filter++ = '\0';
	for (p = buf; n < MAX_FAULT_FIELDS;) {
		fld[n++] = p;
		p = strchr(p, ':');
		if (!p)
			break;
		*p++ = '\0';
	}
	if (p) {
		tool_log(TOOL_LOG_ERR, "rmd-sim: %s \"%s\": too many ':' fields; faults: %s", where,
			 spec, FAULT_SYNTAX);
		return -EINVAL;
	}
	kind = rmd_sim_fault_kind_from_name(fld[0]);
	if (kind < 0) {
		tool_log(TOOL_LOG_ERR, "rmd-sim: %s \"%s\": unknown fault \"%s\"; faults: %s",
			 where, spec, fld[0], FAULT_SYNTAX);
		return -EINVAL;
	}
	memset(&f, 0, sizeof(f));
	f.kind = (enum rmd_sim_fault_kind)kind;
	per_frame = false;

	switch (f.kind) {
	case RMD_SIM_FAULT_DROP:
	case RMD_SIM_FAULT_GARBAGE:
		per_frame = true;
		if (n != 3)
			return fault_error(where, spec, "expected 3 fields", f.kind);
		if (parse_probability(fld[2], &f.probability) < 0)
			return fault_error(where, spec, "P must be a probability 0..1", f.kind);
		break;
	case RMD_SIM_FAULT_DELAY:
	case RMD_SIM_FAULT_BAD_DLC:
	case RMD_SIM_FAULT_WRONG_ID: {
		double v;

		per_frame = true;
		if (n != 4)
			return fault_error(where, spec, "expected 4 fields", f.kind);
		if (parse_probability(fld[3], &f.probability) < 0)
			return fault_error(where, spec, "P must be a probability 0..1", f.kind);
		if (rmd_sim_parse_real(fld[2], &v) < 0)
			v = -1;
		if (f.kind == RMD_SIM_FAULT_DELAY) {
			if (v < 0 || v > MAX_DELAY_US)
				return fault_error(where, spec, "US must be 0..10000000 µs",
						   f.kind);
			f.param = (int64_t)llround(v * 1000.0);
		} else if (f.kind == RMD_SIM_FAULT_BAD_DLC) {
			if (v < 0 || v > 7 || v != floor(v))
				return fault_error(where, spec, "DLC must be 0..7", f.kind);
			f.param = (int64_t)v;
		} else {
			if (v < 1 || v > RMD_MAX_MOTORS || v != floor(v))
				return fault_error(where, spec, "OTHER_ID must be 1..32", f.kind);
			f.param = (int64_t)v;
		}
		break;
	}
	case RMD_SIM_FAULT_DISAPPEAR:
		if (n != 4 && n != 5)
			return fault_error(where, spec, "expected 4 or 5 fields", f.kind);
		if (parse_fault_times(where, spec, &f, "START_S", fld[2], fld[3]) < 0)
			return -EINVAL;
		if (n == 5) {
			if (strcmp(fld[4], "reboot"))
				return fault_error(where, spec,
						   "the 5th field can only be \"reboot\"", f.kind);
			f.param = 1;
		}
		break;
	case RMD_SIM_FAULT_ERROR_FLAG: {
		char names[512];

		if (n != 4 && n != 5)
			return fault_error(where, spec, "expected 4 or 5 fields", f.kind);
		if (parse_error_bits(fld[2], &f.param) < 0) {
			char what[640];

			error_bit_names(names, sizeof(names));
			snprintf(what, sizeof(what),
				 "BITS must be a number 1..0xffff or names joined by '+' (%s)",
				 names);
			return fault_error(where, spec, what, f.kind);
		}
		if (parse_fault_times(where, spec, &f, "AT_S", fld[3], n == 5 ? fld[4] : NULL) < 0)
			return -EINVAL;
		break;
	}
	case RMD_SIM_FAULT_FLOOD: {
		uint64_t id;
		double us;

		if (n != 4 && n != 5)
			return fault_error(where, spec, "expected 4 or 5 fields", f.kind);
		if (rmd_sim_parse_u64(fld[1], &id) < 0 || id > 0x7FF)
			return fault_error(where, spec,
					   "CANID must be an 11-bit identifier 0..0x7ff", f.kind);
		f.can_id = (uint32_t)id;
		if (rmd_sim_parse_real(fld[2], &us) < 0 || us < 100 || us > MAX_DELAY_US)
			return fault_error(where, spec, "PERIOD_US must be 100..10000000 µs",
					   f.kind);
		f.param = (int64_t)llround(us * 1000.0);
		if (parse_fault_times(where, spec, &f, "START_S", fld[3], n == 5 ? fld[4] : NULL) <
		    0)
			return -EINVAL;
		break;
	}
	case RMD_SIM_FAULT_BUS_POWER:
		/* every motor: it cannot make the wire refuse acknowledgements (docs/rmd-sim.md) */
		if (n != 3)
			return fault_error(where, spec, "expected 3 fields", f.kind);
		if (parse_fault_times(where, spec, &f, "START_S", fld[1], fld[2]) < 0)
			return -EINVAL;
		break;
	case RMD_SIM_FAULT_BUS_OFF:
		tool_log(
			TOOL_LOG_ERR,
			"rmd-sim: %s \"%s\": bus_off cannot be injected on a real wire (the "
			"kernel's CAN controller owns the bus state); use the in-process sim bus, or "
			"`ip link set IFACE down`",
			where, spec);
		return -EINVAL;
	case RMD_SIM_FAULT_COUNT:
	default:
		return fault_error(where, spec, "unknown fault", f.kind);
	}

	if (f.kind != RMD_SIM_FAULT_FLOOD && f.kind != RMD_SIM_FAULT_BUS_POWER &&
	    parse_fault_motor(fld[1], &f.motor_id) < 0)
		return fault_error(where, spec, "ID must be a motor id 1..32 or * (every motor)",
				   f.kind);
	if (window && !per_frame)
		return fault_error(where, spec,
				   "this fault takes its window in its fields, not '@'", f.kind);
	if (filter && (!per_frame || parse_fault_filter(filter, &f) < 0))
		return fault_error(where, spec,
				   "/CMD[,COUNT] (a command byte 1..0xff, at most COUNT frames) is "
				   "for per-frame faults",
				   f.kind);
	if (window) {
		char *dash = strchr(window, '-');

		if (!dash)
			return fault_error(where, spec,
					   "the window is @START_S-END_S (END_S may be "
					   "empty)",
					   f.kind);
		*dash = '\0';
		if (parse_seconds(window, &f.start_ns) < 0 ||
		    (dash[1] && parse_seconds(dash + 1, &f.end_ns) < 0))
			return fault_error(where, spec, "window times must be 0..1e6 s", f.kind);
	}
	if (f.end_ns && f.end_ns <= f.start_ns)
		return fault_error(where, spec, "the end must come after the start", f.kind);
	if (c->n_faults >= RMD_SIM_MAX_FAULTS) {
		tool_log(TOOL_LOG_ERR, "rmd-sim: %s \"%s\": more than %d faults", where, spec,
			 RMD_SIM_MAX_FAULTS);
		return -EINVAL;
	}
	c->faults[c->n_faults] = f;
	snprintf(c->fault_text[c->n_faults], sizeof(c->fault_text[0]), "%s", spec);
	snprintf(c->fault_where[c->n_faults], sizeof(c->fault_where[0]), "%s", where);
	c->n_faults++;
	return 0;
}

/* -------------------------------------------------------------------------- */
/* Settings                                                                   */

void sim_config_init(struct sim_config *c)
{
	memset(c, 0, sizeof(*c));
	c->wire = SIM_WIRE_NONE;
	c->baud = RMD_CONFIG_DEFAULT_BAUD; /* as rmdd and rmdctl */
	c->motors = 1;
	c->seed = 1;
	c->verbosity = SIM_NORMAL;
}

/* Key with '_' as '-', lower case; false when it does not fit. */
static bool normalize_key(const char *key, char out[SIM_KEY_MAX])
{
	size_t n = strlen(key);

	if (n == 0 || n >= SIM_KEY_MAX)
		return false;
	for (size_t i = 0; i <= n; i++)
		out[i] = key[i] == '_' ? '-' : (char)tolower((unsigned char)key[i]);
	return true;
}

/* Log `rmd-sim: WHERE "VALUE": expected ...`; returns -EINVAL. */
__attribute__((format(printf, 3, 4))) static int expected(const char *where, const char *value,
							  const char *fmt, ...)
{
	char what[256];
	va_list ap;

	va_start(ap, fmt);
	vsnprintf(what, sizeof(what), fmt, ap);
	va_end(ap);
	tool_log(TOOL_LOG_ERR, "rmd-sim: %s \"%s\": expected %s", where, value, what);
	return -EINVAL;
}

static int set_global(struct sim_config *c, const char *key, const char *value, const char *where)
{
	if (!strcmp(key, "can")) {
		if (!*value || strlen(value) >= IFNAMSIZ || strchr(value, '/') ||
		    strpbrk(value, " \t:")) {
			return expected(where, value,
					"a network interface name of 1..%d characters without '/', "
					"':' or blanks (e.g. can0, vcan0)",
					IFNAMSIZ - 1);
		}
		c->wire = SIM_WIRE_CAN;
		snprintf(c->device, sizeof(c->device), "%s", value);
		return 0;
	}
	if (!strcmp(key, "serial")) {
		if (!*value || strlen(value) >= sizeof(c->device)) {
			return expected(
				where, value,
				"a serial device path of 1..%zu characters (e.g. /dev/ttyUSB0)",
				sizeof(c->device) - 1);
		}
		c->wire = SIM_WIRE_SERIAL;
		snprintf(c->device, sizeof(c->device), "%s", value);
		return 0;
	}
	if (!strcmp(key, "baud")) {
		uint64_t b;

		if (rmd_sim_parse_u64(value, &b) == 0 && b <= UINT32_MAX &&
		    rmd_rs485_baud_speed((uint32_t)b, NULL) == 0) {
			c->baud = (uint32_t)b;
			snprintf(c->baud_where, sizeof(c->baud_where), "%s", where);
			return 0;
		}
		return expected(where, value, BAUD_LIST);
	}
	if (!strcmp(key, "local-echo")) {
		if (rmd_sim_parse_bool(value, &c->local_echo) < 0)
			return expected(where, value, "yes or no");
		snprintf(c->echo_where, sizeof(c->echo_where), "%s", where);
		return 0;
	}
	if (!strcmp(key, "motors")) {
		if (parse_motors(value, &c->motors) < 0)
			return expected(where, value,
					"motor ids 1..32 as a list of ids and ascending ranges, "
					"e.g. 1-4,7");
		return 0;
	}
	if (!strcmp(key, "fault"))
		return parse_fault(c, value, where);
	if (!strcmp(key, "seed")) {
		if (rmd_sim_parse_u64(value, &c->seed) < 0)
			return expected(where, value,
					"an unsigned 64-bit integer (decimal, or hex with 0x)");
		return 0;
	}
	if (!strcmp(key, "verbosity")) {
		if (!strcasecmp(value, "quiet")) {
			c->verbosity = SIM_QUIET;
		} else if (!strcasecmp(value, "normal")) {
			c->verbosity = SIM_NORMAL;
		} else if (!strcasecmp(value, "frames")) {
			c->verbosity = SIM_FRAMES;
		} else {
			return expected(where, value, "quiet, normal or frames");
		}
		tool_log_set_level((int)c->verbosity);
		return 0;
	}
	tool_log(TOOL_LOG_ERR, "rmd-sim: %s: unknown setting", where);
	return -EINVAL;
}

int sim_config_set(struct sim_config *c, uint8_t motor, const char *key, const char *value,
		   const char *where)
{
	char k[SIM_KEY_MAX], allowed[256];
	const struct rmd_sim_param *spec;
	struct rmd_sim_motor_params scratch;
	struct sim_setting *s;

	if (!normalize_key(key, k)) {
		tool_log(TOOL_LOG_ERR,
			 "rmd-sim: %s: \"%s\" is not a setting (rmd-sim --help lists "
			 "them)",
			 where, key);
		return -EINVAL;
	}
	if (is_global(k)) {
		if (motor) {
			tool_log(
				TOOL_LOG_ERR,
				"rmd-sim: %s: \"%s\" applies to the whole program, not to motor %u "
				"(put it before any [motor N] section, without N:)",
				where, k, motor);
			return -EINVAL;
		}
		return set_global(c, k, value, where);
	}
	spec = rmd_sim_param_find(k);
	if (!spec) {
		tool_log(TOOL_LOG_ERR,
			 "rmd-sim: %s: \"%s\" is not a setting (rmd-sim --help lists "
			 "them)",
			 where, key);
		return -EINVAL;
	}
	rmd_sim_motor_params_default(&scratch, motor ? motor : 1, RMD_PROTO_V3);
	if (rmd_sim_param_parse_file(&scratch, spec, value, allowed, sizeof(allowed)) < 0)
		return expected(where, value, "%s", allowed);
	if (strlen(value) >= SIM_VALUE_MAX) {
		tool_log(TOOL_LOG_ERR, "rmd-sim: %s: value longer than %d characters", where,
			 SIM_VALUE_MAX - 1);
		return -EINVAL;
	}
	if (c->n_settings >= SIM_MAX_SETTINGS) {
		tool_log(TOOL_LOG_ERR, "rmd-sim: %s: more than %d settings", where,
			 SIM_MAX_SETTINGS);
		return -EINVAL;
	}
	s = &c->settings[c->n_settings++];
	s->motor = motor;
	snprintf(s->key, sizeof(s->key), "%s", k);
	snprintf(s->value, sizeof(s->value), "%s", value);
	snprintf(s->where, sizeof(s->where), "%s", where);
	if (motor && !(c->motor_refs & (UINT32_C(1) << (motor - 1)))) {
		c->motor_refs |= UINT32_C(1) << (motor - 1);
		snprintf(c->motor_ref_where[motor - 1], sizeof(c->motor_ref_where[0]), "%s", where);
	}
	return 0;
}

int sim_config_set_arg(struct sim_config *c, const char *arg, const char *where)
{
	char key[SIM_KEY_MAX + 8], w[SIM_WHERE_MAX];
	const char *eq = strchr(arg, '='), *colon, *k = arg;
	uint64_t id = 0;
	size_t n;

	colon = strchr(arg, ':');
	if (colon && eq && colon < eq) {
		char num[8];

		n = (size_t)(colon - arg);
		if (n == 0 || n >= sizeof(num))
			goto bad;
		memcpy(num, arg, n);
		num[n] = '\0';
		if (rmd_sim_parse_u64(num, &id) < 0 || id < 1 || id > RMD_MAX_MOTORS)
			goto bad;
		k = colon + 1;
	}
	if (!eq || eq == k || (size_t)(eq - k) >= sizeof(key))
		goto bad;
	n = (size_t)(eq - k);
	memcpy(key, k, n);
	key[n] = '\0';
	snprintf(w, sizeof(w), "%s %.*s", where, (int)(eq - arg), arg);
	return sim_config_set(c, (uint8_t)id, key, eq + 1, w);
bad:
	tool_log(TOOL_LOG_ERR,
		 "rmd-sim: %s \"%s\": expected [ID:]KEY=VALUE, ID a motor id 1..32, KEY a motor "
		 "parameter (rmd-sim --help lists them)",
		 where, arg);
	return -EINVAL;
}

/* -------------------------------------------------------------------------- */
/* Config file                                                                */

static char *trim(char *s)
{
	char *e;

	while (isspace((unsigned char)*s))
		s++;
	e = s + strlen(s);
	while (e > s && isspace((unsigned char)e[-1]))
		*--e = '\0';
	return s;
}

/* "[motor N]" or "[global]": the section's motor (0: global), or -EINVAL. */
static int parse_section(char *line)
{
	char *end = strchr(line, ']'), *s;
	uint64_t id;

	if (!end || *trim(end + 1))
		return -EINVAL;
	*end = '\0';
	s = trim(line + 1);
	if (!strcasecmp(s, "global"))
		return 0;
	if (strncasecmp(s, "motor", 5) || !isspace((unsigned char)s[5]))
		return -EINVAL;
	s = trim(s + 5);
	if (rmd_sim_parse_u64(s, &id) < 0 || id < 1 || id > RMD_MAX_MOTORS)
		return -EINVAL;
	return (int)id;
}

/* One line of a config file (its text in line[], modified); 0 or -EINVAL, logged. */
static int config_line(struct sim_config *c, const char *path, unsigned lineno, char *line,
		       int *motor)
{
	char where[SIM_WHERE_MAX], *s, *eq, *key, *value, *hash;

	s = trim(line);
	if (!*s || *s == '#' || *s == ';')
		return 0;
	/* A comment after a section or a value starts with a blank and '#'. */
	for (hash = strchr(s, '#'); hash; hash = strchr(hash + 1, '#')) {
		if (isspace((unsigned char)hash[-1])) {
			*hash = '\0';
			s = trim(s);
			break;
		}
	}
	if (*s == '[') {
		int m = parse_section(s);

		if (m < 0) {
			tool_log(TOOL_LOG_ERR,
				 "rmd-sim: %s:%u: expected a section [global] or [motor N], "
				 "N 1..32",
				 path, lineno);
			return -EINVAL;
		}
		*motor = m;
		if (m && !(c->motor_refs & (UINT32_C(1) << (m - 1)))) {
			c->motor_refs |= UINT32_C(1) << (m - 1);
			snprintf(c->motor_ref_where[m - 1], sizeof(c->motor_ref_where[0]),
				 "%s:%u: [motor %d]", path, lineno, m);
		}
		return 0;
	}
	eq = strchr(s, '=');
	if (!eq) {
		tool_log(TOOL_LOG_ERR,
			 "rmd-sim: %s:%u: expected KEY = VALUE, a [section] or "
			 "a # comment",
			 path, lineno);
		return -EINVAL;
	}
	*eq = '\0';
	key = trim(s);
	value = eq + 1;
	value = trim(value);
	snprintf(where, sizeof(where), "%s:%u: %s", path, lineno, key);
	if (!strcasecmp(key, "config")) {
		tool_log(TOOL_LOG_ERR, "rmd-sim: %s: config files do not include others", where);
		return -EINVAL;
	}
	return sim_config_set(c, (uint8_t)*motor, key, value, where) < 0 ? -EINVAL : 0;
}

/* Error lines a config file may produce before the rest is not read (rmdd's cap too). */
#define FILE_ERRORS_MAX 32

/*
 * The file is read as rmdd's is (rmd_config_file_read): a regular file only,
 * so never blocking on a FIFO or reading /dev/zero, at most
 * RMD_CONFIG_FILE_MAX bytes, no NUL byte; at most FILE_ERRORS_MAX errors.
 */
int sim_config_file(struct sim_config *c, const char *path)
{
	char line[1024], why[160];
	unsigned lineno = 0, nerr = 0, nul_line;
	int motor = 0, r;
	char *text, *next;
	size_t len;

	r = rmd_config_file_read(path, &text, &len, &nul_line, why, sizeof(why));
	if (r < 0) {
		if (nul_line)
			tool_log(TOOL_LOG_ERR, "rmd-sim: %s:%u: %s", path, nul_line, why);
		else
			tool_log(TOOL_LOG_ERR, "rmd-sim: --config %s: %s", path, why);
		return r;
	}
	for (next = text; *next;) {
		char *nl = strchr(next, '\n');
		size_t n = nl ? (size_t)(nl - next) : strlen(next);

		lineno++;
		if (n > sizeof(line) - 2) {
			tool_log(TOOL_LOG_ERR, "rmd-sim: %s:%u: line longer than %zu characters",
				 path, lineno, sizeof(line) - 2);
			r = -EINVAL;
			break;
		}
		memcpy(line, next, n);
		line[n] = '\0';
		next += nl ? n + 1 : n;
		if (config_line(c, path, lineno, line, &motor) < 0) {
			r = -EINVAL;
			if (++nerr == FILE_ERRORS_MAX) {
				if (*next)
					tool_log(
						TOOL_LOG_ERR,
						"rmd-sim: %s: more errors not shown; the rest of the "
						"file is not read",
						path);
				break;
			}
		}
	}
	free(text);
	return r;
}

/* -------------------------------------------------------------------------- */
/* rmdd.yaml                                                                  */

bool sim_config_is_yaml(const char *path)
{
	const char *dot = strrchr(path, '.');

	return dot && !strchr(dot, '/') && (!strcasecmp(dot, ".yaml") || !strcasecmp(dot, ".yml"));
}

/* The loader's error lines, each as one log line. */
static void log_lines(const char *text)
{
	while (*text) {
		const char *nl = strchr(text, '\n');
		int n = nl ? (int)(nl - text) : (int)strlen(text);

		tool_log(TOOL_LOG_ERR, "rmd-sim: %.*s", n, text);
		text += n + (nl ? 1 : 0);
	}
}

/* The bus of cfg to simulate (sim_config_yaml()): its index, or -EINVAL (logged). */
static int pick_bus(const struct rmd_config *cfg, const char *path, const char *bus,
		    const char *wire)
{
	char names[RMD_MAX_BUSES * (RMD_CONFIG_NAME_LEN + RMD_CONFIG_PATH_LEN + 8)];
	int n = 0, only = -1, match = -1, nmatch = 0;
	size_t k = 0;
	bool serial;

	names[0] = '\0';
	for (unsigned i = 0; i < cfg->n_buses; i++) {
		const char *w = rmd_config_bus_wire(&cfg->buses[i], &serial);

		if (!w)
			continue;
		if (k < sizeof(names))
			k += (size_t)snprintf(names + k, sizeof(names) - k, "%s%s (%s)",
					      k ? ", " : "", cfg->buses[i].name, w);
		n++;
		only = (int)i;
		if (wire && !strcmp(w, wire)) {
			match = (int)i;
			nmatch++;
		}
	}
	if (bus) {
		int i = rmd_config_bus_find(cfg, bus);

		if (i < 0) {
			tool_log(TOOL_LOG_ERR, "rmd-sim: --bus %s: %s has no such bus; %s%s", bus,
				 path,
				 n ? "buses rmd-sim simulates: " : "and no socketcan or rs485 bus",
				 names);
			return -EINVAL;
		}
		if (!rmd_config_bus_wire(&cfg->buses[i], &serial)) {
			tool_log(TOOL_LOG_ERR,
				 "rmd-sim: --bus %s: a sim bus, which rmdd simulates itself; "
				 "rmd-sim simulates a socketcan or rs485 bus%s%s",
				 bus, n ? ": " : "", names);
			return -EINVAL;
		}
		return i;
	}
	if (nmatch == 1)
		return match;
	if (n == 1)
		return only;
	if (n == 0)
		tool_log(TOOL_LOG_ERR,
			 "rmd-sim: %s: no socketcan or rs485 bus to simulate (rmdd simulates its "
			 "sim buses itself)",
			 path);
	else
		tool_log(TOOL_LOG_ERR,
			 "rmd-sim: %s: %d buses rmd-sim could simulate: %s; choose one with --bus "
			 "NAME",
			 path, n, names);
	return -EINVAL;
}

/* The faults of the file's bus bi (checked by the loader) after those recorded. */
static int yaml_faults(struct sim_config *c, const char *path, unsigned bi,
		       const struct rmd_sim_bus_setup *sb)
{
	for (unsigned i = 0; i < sb->n_faults; i++) {
		const struct rmd_sim_fault *f = &sb->faults[i];
		char motor[16] = "";

		if (c->n_faults >= RMD_SIM_MAX_FAULTS) {
			tool_log(TOOL_LOG_ERR,
				 "rmd-sim: %s: buses[%u].sim.faults[%u]: more than %d faults", path,
				 bi, i, RMD_SIM_MAX_FAULTS);
			return -EINVAL;
		}
		if (f->motor_id)
			snprintf(motor, sizeof(motor), " motor %u", f->motor_id);
		c->faults[c->n_faults] = *f;
		snprintf(c->fault_text[c->n_faults], sizeof(c->fault_text[0]),
			 "%s%s (buses[%u].sim.faults[%u])", rmd_sim_fault_kind_name(f->kind), motor,
			 bi, i);
		snprintf(c->fault_where[c->n_faults], sizeof(c->fault_where[0]),
			 "%s: buses[%u].sim.faults[%u]", path, bi, i);
		c->n_faults++;
	}
	return 0;
}

int sim_config_yaml(struct sim_config *c, const char *path, const char *bus, const char *wire)
{
	static char err[8192];
	struct rmd_config *cfg = malloc(sizeof(*cfg));
	struct rmd_sim_setup *sim = malloc(sizeof(*sim));
	char where[SIM_WHERE_MAX], list[512];
	const struct rmd_config_bus *b;
	const char *dev;
	uint32_t mask = 0;
	size_t k = 0;
	bool serial;
	int r, bi;

	if (!cfg || !sim) {
		tool_log(TOOL_LOG_ERR, "rmd-sim: --config %s: out of memory", path);
		r = -ENOMEM;
		goto out;
	}
	r = rmd_config_load(path, cfg, sim, err, sizeof(err));
	if (r < 0) {
		log_lines(err);
		goto out;
	}
	bi = pick_bus(cfg, path, bus, wire);
	if (bi < 0) {
		r = bi;
		goto out;
	}
	b = &cfg->buses[bi];
	dev = rmd_config_bus_wire(b, &serial);
	snprintf(where, sizeof(where), "%s: buses[%d] (%s)", path, bi, b->name);
	r = set_global(c, serial ? "serial" : "can", dev, where);
	if (r < 0)
		goto out;
	if (serial)
		c->baud = b->baud; /* not baud_where: --can may replace the wire */
	list[0] = '\0';
	for (unsigned i = 0; i < cfg->n_motors; i++) {
		const struct rmd_config_motor *m = &cfg->motors[i];

		if (m->bus != (unsigned)bi)
			continue;
		mask |= UINT32_C(1) << (m->id - 1);
		c->base[m->id - 1] = sim->motors[i];
		if (k < sizeof(list))
			k += (size_t)snprintf(list + k, sizeof(list) - k, "%s%u %s", k ? ", " : "",
					      m->id, m->name);
	}
	/* motors on the wire the file does not list (buses[].sim.strays) */
	for (unsigned j = 0; j < sim->buses[bi].n_strays; j++) {
		const struct rmd_sim_motor_params *p = &sim->buses[bi].strays[j];

		mask |= UINT32_C(1) << (p->id - 1);
		c->base[p->id - 1] = *p;
		if (k < sizeof(list))
			k += (size_t)snprintf(list + k, sizeof(list) - k, "%s%u (a stray)",
					      k ? ", " : "", p->id);
	}
	if (!mask) {
		tool_log(TOOL_LOG_ERR, "rmd-sim: %s: no motor is on it", where);
		r = -EINVAL;
		goto out;
	}
	/* the joints of this bus's motors, by id (the same world code as rmdd's sim buses) */
	c->physics = sim->physics;
	c->physics.n_joints = 0;
	for (unsigned j = 0; j < sim->physics.n_joints; j++) {
		const struct rmd_sim_physics_joint *pj = &sim->physics.joints[j];

		if (cfg->motors[pj->motor].bus != (unsigned)bi)
			continue;
		c->physics.joints[c->physics.n_joints] = *pj;
		c->physics.joints[c->physics.n_joints++].motor = cfg->motors[pj->motor].id - 1u;
	}
	c->motors = mask;
	c->base_set = mask;
	c->seed = sim->buses[bi].seed ? sim->buses[bi].seed : 1;
	r = yaml_faults(c, path, (unsigned)bi, &sim->buses[bi]);
	snprintf(c->yaml_bus, sizeof(c->yaml_bus), "%s: bus %s, motors %s", path, b->name, list);
out:
	free(sim);
	free(cfg);
	return r;
}

/* -------------------------------------------------------------------------- */
/* Final checks                                                               */

/* splitmix64, to give each motor its own jitter stream from the one seed. */
static uint64_t mix(uint64_t x)
{
	x += UINT64_C(0x9E3779B97F4A7C15);
	x = (x ^ (x >> 30)) * UINT64_C(0xBF58476D1CE4E5B9);
	x = (x ^ (x >> 27)) * UINT64_C(0x94D049BB133111EB);
	x ^= x >> 31;
	return x ? x : 1;
}

/* A pair of motor settings where lo must stay below hi.  Returns 0 or -EINVAL, logged. */
static int check_below(uint8_t id, const char *lo_name, double lo, const char *hi_name, double hi,
		       const char *unit)
{
	if (lo < hi)
		return 0;
	tool_log(TOOL_LOG_ERR, "rmd-sim: motor %u: %s (%g %s) must be below %s (%g %s)", id,
		 lo_name, lo, unit, hi_name, hi, unit);
	return -EINVAL;
}

static int build_motor(struct sim_config *c, uint8_t id)
{
	struct rmd_sim_motor_params *p = &c->params[id - 1];
	char allowed[256];

	if (c->base_set & (UINT32_C(1) << (id - 1)))
		*p = c->base[id - 1];
	else
		rmd_sim_motor_params_default(p, id, RMD_PROTO_V3);
	/* Every global setting, then the motor's own. */
	for (int pass = 0; pass < 2; pass++) {
		for (unsigned i = 0; i < c->n_settings; i++) {
			const struct sim_setting *s = &c->settings[i];

			if (pass == 0 ? s->motor != 0 : s->motor != id)
				continue;
			if (rmd_sim_param_parse_file(p, rmd_sim_param_find(s->key), s->value,
						     allowed, sizeof(allowed)) < 0)
				return -EINVAL; /* checked when recorded */
		}
	}
	p->id = id;
	p->seed = mix(c->seed ^ ((uint64_t)id << 56));
	if (check_below(id, "over-temp-clear", p->over_temp_clear_c, "over-temp", p->over_temp_c,
			"°C") < 0 ||
	    check_below(id, "under-voltage", p->under_voltage_v, "over-voltage", p->over_voltage_v,
			"V") < 0)
		return -EINVAL;
	if (c->wire == SIM_WIRE_SERIAL &&
	    !rmd_dialect_has(rmd_dialect(p->proto), RMD_DIALECT_RS485)) {
		tool_log(TOOL_LOG_ERR,
			 "rmd-sim: motor %u: protocol %s on --serial: %s motors have no RS485 "
			 "interface (the %s manual is CAN only); use --can, or protocol v3",
			 id, rmd_proto_key(p->proto), rmd_proto_name(p->proto),
			 rmd_proto_name(p->proto));
		return -EINVAL;
	}
	return 0;
}

int sim_config_finish(struct sim_config *c)
{
	char list[128];
	int r = 0;

	sim_format_motors(c->motors, list, sizeof(list));
	if (c->wire == SIM_WIRE_NONE) {
		tool_log(TOOL_LOG_ERR, "rmd-sim: no wire: give --can IFACE or --serial DEVICE "
				       "(rmd-sim --help)");
		return -EINVAL;
	}
	if (c->wire == SIM_WIRE_CAN && c->baud_where[0]) {
		tool_log(TOOL_LOG_ERR,
			 "rmd-sim: %s: a baud rate applies to --serial only; CAN's "
			 "bitrate belongs to the interface (ip link set ... bitrate)",
			 c->baud_where);
		return -EINVAL;
	}
	if (c->wire == SIM_WIRE_CAN && c->echo_where[0] && c->local_echo) {
		tool_log(TOOL_LOG_ERR, "rmd-sim: %s: local echo applies to --serial only",
			 c->echo_where);
		return -EINVAL;
	}
	for (unsigned i = 0; i < RMD_MAX_MOTORS; i++) {
		uint32_t bit = UINT32_C(1) << i;

		if ((c->motor_refs & bit) && !(c->motors & bit)) {
			tool_log(
				TOOL_LOG_ERR,
				"rmd-sim: %s: configures motor %u, which is not simulated (motors: "
				"%s); add it to --motors / motors =",
				c->motor_ref_where[i], i + 1, list);
			r = -EINVAL;
		}
	}
	for (unsigned i = 0; i < c->n_faults; i++) {
		const struct rmd_sim_fault *f = &c->faults[i];

		if (f->kind != RMD_SIM_FAULT_FLOOD && f->motor_id &&
		    !(c->motors & (UINT32_C(1) << (f->motor_id - 1)))) {
			tool_log(TOOL_LOG_ERR,
				 "rmd-sim: %s \"%s\": motor %u is not simulated (motors: %s)",
				 c->fault_where[i], c->fault_text[i], f->motor_id, list);
			r = -EINVAL;
		}
		if (f->kind == RMD_SIM_FAULT_FLOOD && c->wire != SIM_WIRE_CAN) {
			tool_log(TOOL_LOG_ERR,
				 "rmd-sim: %s \"%s\": flood needs --can (an RS485 line has no "
				 "arbitration to win)",
				 c->fault_where[i], c->fault_text[i]);
			r = -EINVAL;
		}
	}
	if (r < 0)
		return r;
	for (unsigned i = 0; i < RMD_MAX_MOTORS; i++) {
		if ((c->motors & (UINT32_C(1) << i)) && build_motor(c, (uint8_t)(i + 1)) < 0)
			r = -EINVAL;
	}
	return r;
}
