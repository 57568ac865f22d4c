// SPDX-License-Identifier: MIT
/*
 * rmdctl dump and restore: every motor's readable settings as YAML, and
 * back (what moteus users get from --dump-config / --restore-config).
 *
 * What V3 lets a host read back, and so what a dump holds (V3 §2): the PI
 * gains (0x30), the position-planning acceleration (0x42: one value, the
 * 0x43 index 0 one) and the multi-turn zero offset in use (0x62); the id
 * is the motor's address, model (0xB5) and firmware date (0xB2) are
 * recorded for the reader.  V4 (V4.2 §2.1, §2.4) the same, its seven
 * float gains read one by index, and 0x42 asked for index 0.  The file
 * names its dialect (`protocol:`): the gains of one layout mean nothing
 * in another, so restore refuses a file of another dialect than
 * --protocol, and with --force writes all but the gains.  What it cannot read: the comm-loss time (0xB3
 * only writes, §2.30), the CAN-ID filter and other 0x20 functions (§2.33
 * only writes), the baud rate (0xB4, §2.31), and the other three
 * accelerations (0x43 index 1..3).  restore writes comm_loss_ms when a
 * file names it, always (it cannot tell whether it differs).
 *
 * restore reads the motors first, prints what would change and asks once
 * (--yes); unchanged values are not written.  Writes go to ROM: gains
 * 0x32, acceleration 0x43 index 0 (RAM and ROM), zero offset 0x63 (used
 * after a reset or power cycle), 0xB3.  Non-rt.
 */
#include <errno.h>
#include <inttypes.h>
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <time.h>

#include <yaml.h>

#include "rmd/codec.h"
#include "rmdctl.h"

/* The readable settings of one motor, and which a file gives. */
struct settings {
	uint8_t id;
	/* the dialect's gains (pid_slots order): V3 integers, V4 binary32 bits */
	int64_t pid[RMD_PID_SLOTS_MAX];
	int64_t accel_dps2;
	int64_t zero_offset;
	int64_t comm_loss_ms; /* restore: -1 when the file does not name it */
	bool has_pid, has_accel, has_zero;
	unsigned line; /* of the entry in the file */
};

/* Whether the dialect's gains are reals (V4.2 §2.1: binary32), not integers (V3 §2.1). */
static bool float_gains(const struct rmd_dialect *dl)
{
	const struct rmd_field_spec *fs = rmd_pid_spec(dl, 0);

	return fs && fs->is_float;
}

/* Gain k of the dialect's layout: its key ("speed_kp"). */
static const char *pid_key(const struct rmd_dialect *dl, unsigned k)
{
	return rmd_field_key((enum rmd_field)dl->pid_slots[k].field);
}

static int dialect_ok(const struct dev *d)
{
	const struct rmd_dialect *dl = rmdctl_dialect(d);

	/* gains to read (V3 §2.1 in one frame, V4.2 §2.1 by index), 0xB5 and 0xB2 */
	if (dl->n_pid_slots && rmd_dialect_has(dl, RMD_DIALECT_MODEL_B5 | RMD_DIALECT_VERSION_B2))
		return 0;
	tool_log(TOOL_LOG_ERR, "%s speaks protocols V3 and V4 only (not %s)", d->cmd->name,
		 dl->name);
	return RMDCTL_EXIT_USAGE;
}

/*
 * Read motor s->id's settings (the gains, 0x42, 0x62; 0xB5 and 0xB2 into
 * info when given), in one batch.
 */
static int read_settings(struct dev *d, struct settings *s, struct rec *info)
{
	static const uint8_t cmds[] = { 0x42, 0x62, 0xB5, 0xB2 };
	const struct rmd_dialect *dl = rmdctl_dialect(d);
	struct req q[RMD_PID_SLOTS_MAX + sizeof(cmds)];
	unsigned n_pid = rmdctl_pid_read_reqs(d, s->id, q), n = n_pid + (info ? 4 : 2);
	struct rmd_pid_set gains;
	int r;

	/* V4.2 §2.4: 0x42 asks for an index, 0 the position-planning acceleration */
	for (unsigned i = n_pid; i < n; i++) {
		rmdctl_req_init(&q[i], s->id, cmds[i - n_pid]);
		rmd_msg_set(&q[i].msg, RMD_FLD_INDEX, 0);
	}
	r = rmdctl_run_reqs(d, q, n);
	if (r)
		return r;
	if (rmdctl_report_failed(d, q, n) || rmdctl_pid_gather(d, q, n, &gains))
		return RMDCTL_EXIT_DATA;
	for (unsigned k = 0; k < dl->n_pid_slots; k++)
		s->pid[k] = gains.raw[k];
	s->accel_dps2 = q[n_pid].rep.v[RMD_FLD_ACCEL];
	s->zero_offset = q[n_pid + 1].rep.v[RMD_FLD_ENCODER_OFF];
	s->has_pid = s->has_accel = s->has_zero = true;
	if (info)
		for (unsigned i = n_pid + 2; i < n; i++)
			rmdctl_rec_add_req(info, d, &q[i], true);
	return 0;
}

/* Gain value raw of the dialect as text: an integer, or a binary32 in nine digits. */
static const char *gain_text(const struct rmd_dialect *dl, int64_t raw, char *buf, size_t size)
{
	if (float_gains(dl)) {
		uint32_t u = (uint32_t)raw;
		float x;

		memcpy(&x, &u, sizeof(x));
		snprintf(buf, size, "%.9g", x);
	} else {
		snprintf(buf, size, "%" PRId64, raw);
	}
	return buf;
}

/* ---- dump ------------------------------------------------------------------------------ */

int rmdctl_run_dump(struct dev *d, int argc, char **argv)
{
	uint8_t found[RMD_MAX_MOTORS];
	struct req st[RMD_MAX_MOTORS];
	char stamp[32];
	time_t now = time(NULL);
	int m, r;

	r = dialect_ok(d);
	if (r)
		return r;
	m = rmdctl_ids_probe(d, argc, argv, found, st, ": nothing to dump");
	if (m < 0)
		return -m;
	strftime(stamp, sizeof(stamp), "%Y-%m-%dT%H:%M:%SZ", gmtime(&now));
	printf("# rmdctl dump: the settings of the motors on %s (protocol %s), %s.\n"
	       "# Read back: PID gains (0x30%s), position-planning acceleration (0x42, the\n"
	       "# 0x43 index 0 value), multi-turn zero offset in use (0x62, encoder counts).\n"
	       "# Not readable (%s has no read for them): comm-loss time (0xB3), CAN-ID\n"
	       "# filter and other functions (0x20), baud rate (0xB4), the other\n"
	       "# accelerations (0x43 index 1..3).\n"
	       "# `rmdctl restore FILE` writes back what differs (ROM), after a confirmation;\n"
	       "# a `comm_loss_ms: MS` line added to a motor is written as given.  The\n"
	       "# gains are this protocol's (restore refuses the file for another).\n"
	       "bus: %s\n"
	       "protocol: %s\n"
	       "motors:\n",
	       d->name, rmdctl_dialect(d)->name, stamp,
	       float_gains(rmdctl_dialect(d)) ? ", one float by index" : "",
	       rmdctl_dialect(d)->name, d->name, rmdctl_dialect(d)->key);
	for (int i = 0; i < m; i++) {
		struct settings s = { .id = found[i] };
		struct rec info = { 0 };
		char model[8];

		r = read_settings(d, &s, &info);
		if (r)
			goto out;
		rmd_model_string(info.raw[RMD_FLD_MODEL], model);
		printf("  - id: %u\n"
		       "    model: \"%s\"  # not restored\n"
		       "    firmware: %" PRId64 "  # not restored\n"
		       "    pid: {",
		       s.id, model, info.raw[RMD_FLD_VERSION]);
		for (unsigned k = 0; k < rmdctl_dialect(d)->n_pid_slots; k++) {
			char g[32];

			printf("%s%s: %s", k ? ", " : "", pid_key(rmdctl_dialect(d), k),
			       gain_text(rmdctl_dialect(d), s.pid[k], g, sizeof(g)));
		}
		printf("}\n"
		       "    accel_dps2: %" PRId64 "\n"
		       "    zero_offset: %" PRId64 "\n",
		       s.accel_dps2, s.zero_offset);
	}
	r = RMDCTL_EXIT_OK;
out:
	rmdctl_close_bus(d);
	return r;
}

/* ---- the file -------------------------------------------------------------------------- */

struct file {
	const char *path;
	yaml_document_t doc;
	const struct rmd_dialect *dl; /* its `protocol:`, or --protocol's when it names none */
	char bus[64];		      /* its `bus:`, or "" */
	struct settings motor[RMD_MAX_MOTORS];
	unsigned n;
};

static int bad(const struct file *f, const yaml_node_t *node, const char *what)
{
	tool_log(TOOL_LOG_ERR, "%s:%zu: %s", f->path, node->start_mark.line + 1, what);
	return -EINVAL;
}

/* Pair i of mapping n (a YAML_MAPPING_NODE): its key *k and value *v; false past the last. */
static bool pair_at(struct file *f, const yaml_node_t *n, size_t i, yaml_node_t **k,
		    yaml_node_t **v)
{
	const yaml_node_pair_t *p = n->data.mapping.pairs.start + i;

	if (p >= n->data.mapping.pairs.top)
		return false;
	*k = yaml_document_get_node(&f->doc, p->key);
	*v = yaml_document_get_node(&f->doc, p->value);
	return true;
}

static const char *scalar(const yaml_node_t *n)
{
	return n && n->type == YAML_SCALAR_NODE ? (const char *)n->data.scalar.value : NULL;
}

/* A whole integer scalar in [lo, hi]. */
static int integer(const struct file *f, const yaml_node_t *n, int64_t lo, int64_t hi,
		   const char *key, int64_t *v)
{
	const char *s = scalar(n);
	char *end, msg[160];
	long long x;

	errno = 0;
	x = s ? strtoll(s, &end, 10) : 0;
	if (!s || !*s || *end || errno || x < lo || x > hi) {
		snprintf(msg, sizeof(msg), "%s: want an integer %" PRId64 "..%" PRId64, key, lo,
			 hi);
		return bad(f, n, msg);
	}
	*v = x;
	return 0;
}

/* A real scalar that a binary32 holds (V4.2 §2.2: a float gain), >= 0; its bits into *v. */
static int real_gain(const struct file *f, const yaml_node_t *n, const char *key, int64_t *v)
{
	const char *s = scalar(n);
	char *end, msg[160];
	double x;
	float g;
	uint32_t u;

	errno = 0;
	x = s ? strtod(s, &end) : 0;
	if (!s || !*s || *end || errno || !(x >= 0) || x > 3.4e38) {
		snprintf(msg, sizeof(msg), "%s: want a real >= 0 (a float gain)", key);
		return bad(f, n, msg);
	}
	g = (float)x;
	memcpy(&u, &g, sizeof(u));
	*v = u;
	return 0;
}

static int parse_pid(struct file *f, yaml_node_t *n, struct settings *s)
{
	const struct rmd_dialect *dl = f->dl;
	bool seen[RMD_PID_SLOTS_MAX] = { false };
	yaml_node_t *k, *v;
	char keys[160];
	size_t o = 0;

	for (unsigned i = 0; i < dl->n_pid_slots; i++)
		o += (size_t)snprintf(keys + o, sizeof(keys) - o, "%s%s", i ? ", " : "",
				      pid_key(dl, i));
	if (n->type != YAML_MAPPING_NODE)
		return bad(f, n, "pid: want a mapping of the gains");
	for (size_t pi = 0; pair_at(f, n, pi, &k, &v); pi++) {
		char msg[200];
		unsigned i;

		for (i = 0;
		     i < dl->n_pid_slots && (!scalar(k) || strcmp(scalar(k), pid_key(dl, i))); i++)
			;
		if (i == dl->n_pid_slots) {
			snprintf(msg, sizeof(msg), "pid: unknown key for protocol %s (%s)", dl->key,
				 keys);
			return bad(f, k, msg);
		}
		/* V3 §2.2: uint8 gains; V4.2 §2.2: binary32 */
		if ((float_gains(dl) ? real_gain(f, v, pid_key(dl, i), &s->pid[i]) :
				       integer(f, v, 0, 255, pid_key(dl, i), &s->pid[i])) < 0)
			return -EINVAL;
		seen[i] = true;
	}
	for (unsigned i = 0; i < dl->n_pid_slots; i++)
		if (!seen[i]) {
			char msg[200];

			snprintf(msg, sizeof(msg), "pid: give all the gains of protocol %s (%s)",
				 dl->key, keys);
			return bad(f, n, msg);
		}
	s->has_pid = true;
	return 0;
}

static int parse_motor(struct file *f, yaml_node_t *n, struct settings *s)
{
	yaml_node_t *k, *v;
	int64_t id = 0;

	s->comm_loss_ms = -1;
	s->line = (unsigned)n->start_mark.line + 1;
	if (n->type != YAML_MAPPING_NODE)
		return bad(f, n, "a motor: want a mapping (id: N, pid: {...}, ...)");
	for (size_t pi = 0; pair_at(f, n, pi, &k, &v); pi++) {
		const char *key = scalar(k) ? scalar(k) : "";
		int r = 0;

		if (!strcmp(key, "id"))
			r = integer(f, v, 1, RMD_MAX_MOTORS, key, &id);
		else if (!strcmp(key, "pid"))
			r = parse_pid(f, v, s);
		else if (!strcmp(key, "accel_dps2")) /* V3 §2.5.1 */
			r = integer(f, v, 100, 60000, key, &s->accel_dps2);
		else if (!strcmp(key, "zero_offset"))
			r = integer(f, v, INT32_MIN, INT32_MAX, key, &s->zero_offset);
		else if (!strcmp(key, "comm_loss_ms"))
			r = integer(f, v, 0, UINT32_MAX, key, &s->comm_loss_ms);
		else if (strcmp(key, "model") && strcmp(key, "firmware"))
			r = bad(f, k,
				"unknown key (id, pid, accel_dps2, zero_offset, comm_loss_ms; "
				"model and firmware are ignored)");
		if (r < 0)
			return r;
		s->has_accel |= !strcmp(key, "accel_dps2");
		s->has_zero |= !strcmp(key, "zero_offset");
	}
	if (!id)
		return bad(f, n, "a motor without id");
	s->id = (uint8_t)id;
	return 0;
}

static int parse_file(struct file *f)
{
	yaml_node_t *root, *motors = NULL, *k, *v;
	yaml_parser_t parser;
	FILE *fp = fopen(f->path, "r");
	int r = -EINVAL;

	if (!fp) {
		tool_log(TOOL_LOG_ERR, "%s: %s", f->path, strerror(errno));
		return -errno;
	}
	yaml_parser_initialize(&parser);
	yaml_parser_set_input_file(&parser, fp);
	if (!yaml_parser_load(&parser, &f->doc)) {
		tool_log(TOOL_LOG_ERR, "%s:%zu: %s", f->path, parser.problem_mark.line + 1,
			 parser.problem ? parser.problem : "not YAML");
		yaml_parser_delete(&parser);
		fclose(fp);
		return -EINVAL;
	}
	yaml_parser_delete(&parser);
	fclose(fp);
	root = yaml_document_get_root_node(&f->doc);
	for (size_t pi = 0; root && root->type == YAML_MAPPING_NODE && pair_at(f, root, pi, &k, &v);
	     pi++) {
		const char *key = scalar(k);
		enum rmd_proto proto;

		if (key && !strcmp(key, "motors"))
			motors = v;
		if (key && !strcmp(key, "bus") && scalar(v))
			snprintf(f->bus, sizeof(f->bus), "%s", scalar(v));
		if (key && !strcmp(key, "protocol")) {
			if (!scalar(v) || rmd_proto_parse(scalar(v), &proto) < 0) {
				bad(f, v, "protocol: not a protocol key (v3, v4, ...)");
				goto out;
			}
			f->dl = rmd_dialect(proto);
		}
	}
	if (!motors || motors->type != YAML_SEQUENCE_NODE) {
		tool_log(TOOL_LOG_ERR, "%s: no `motors:` list (write one with rmdctl dump)",
			 f->path);
		goto out;
	}
	for (yaml_node_item_t *it = motors->data.sequence.items.start;
	     it < motors->data.sequence.items.top; it++) {
		yaml_node_t *n = yaml_document_get_node(&f->doc, *it);

		if (f->n == RMD_MAX_MOTORS) {
			bad(f, n, "more than 32 motors");
			goto out;
		}
		if (parse_motor(f, n, &f->motor[f->n]) < 0)
			goto out;
		for (unsigned i = 0; i < f->n; i++)
			if (f->motor[i].id == f->motor[f->n].id) {
				bad(f, n, "this id twice");
				goto out;
			}
		f->n++;
	}
	r = 0;
out:
	yaml_document_delete(&f->doc);
	return r;
}

/* ---- restore --------------------------------------------------------------------------- */

/* One change: a line of the diff, and the request that makes it. */
struct change {
	uint8_t id;
	char text[160];
	struct req q;
};

/*
 * The changes that bring motor `now` (read) to `want` (the file), in
 * dialect dl; returns how many.
 */
static unsigned diff(const struct rmd_dialect *dl, const struct settings *want,
		     const struct settings *now, struct change *c)
{
	struct rmd_pid_set set = { 0 };
	struct rmd_msg m[RMD_PID_SLOTS_MAX];
	unsigned n = 0;
	int nq = 0;

	/*
	 * The gains that differ, to ROM: V3 §2.3 one frame, all six; V4.2 §2.3
	 * one a frame by index, a change each
	 */
	for (unsigned i = 0; want->has_pid && i < dl->n_pid_slots; i++) {
		set.raw[i] = want->pid[i];
		if (want->pid[i] != now->pid[i])
			set.slots |= UINT32_C(1) << i;
	}
	if (set.slots)
		nq = rmd_pid_requests(dl, RMD_PID_WRITE_ROM, &set, m);
	for (int j = 0; j < nq; j++, n++) {
		struct rmd_pid_set carried;
		enum rmd_pid_op op;
		uint32_t named;
		unsigned o = 0;

		rmdctl_req_init(&c[n].q, want->id, m[j].cmd);
		c[n].q.msg = m[j];
		rmd_pid_parse(dl, &m[j], &op, &named, &carried);
		for (unsigned i = 0; i < dl->n_pid_slots; i++) {
			char a[32], b[32];

			if (!(carried.slots & set.slots & (UINT32_C(1) << i)))
				continue;
			o += (unsigned)snprintf(c[n].text + o, sizeof(c[n].text) - o,
						"%s %s %s -> %s", o ? "," : "pid:", pid_key(dl, i),
						gain_text(dl, now->pid[i], a, sizeof(a)),
						gain_text(dl, want->pid[i], b, sizeof(b)));
		}
	}
	if (want->has_accel && want->accel_dps2 != now->accel_dps2) {
		rmdctl_req_init(&c[n].q, want->id, 0x43); /* V3 §2.5: index 0, RAM and ROM */
		rmd_msg_set(&c[n].q.msg, RMD_FLD_INDEX, 0);
		rmd_msg_set(&c[n].q.msg, RMD_FLD_ACCEL, want->accel_dps2);
		snprintf(c[n++].text, sizeof(c->text), "accel_dps2 %" PRId64 " -> %" PRId64,
			 now->accel_dps2, want->accel_dps2);
	}
	if (want->has_zero && want->zero_offset != now->zero_offset) {
		rmdctl_req_init(&c[n].q, want->id, 0x63); /* V3 §2.9: ROM, after a restart */
		rmd_msg_set(&c[n].q.msg, RMD_FLD_ENCODER_OFF, want->zero_offset);
		snprintf(c[n++].text, sizeof(c->text),
			 "zero_offset %" PRId64 " -> %" PRId64 " (used after `rmdctl reset %u`)",
			 now->zero_offset, want->zero_offset, want->id);
	}
	if (want->comm_loss_ms >= 0) {
		rmdctl_req_init(&c[n].q, want->id, 0xB3); /* V3 §2.30: ROM */
		rmd_msg_set(&c[n].q.msg, RMD_FLD_TIMEOUT, want->comm_loss_ms);
		snprintf(c[n++].text, sizeof(c->text),
			 "comm_loss_ms -> %" PRId64 " (cannot be read back: written as given)",
			 want->comm_loss_ms);
	}
	for (unsigned i = 0; i < n; i++)
		c[i].id = want->id;
	return n;
}

/* V3 §2.30 example 2: 0xB3 may be answered with zeros instead of the echo. */
static bool b3_zeros(const struct req *q)
{
	return q->msg.cmd == 0xB3 && q->answered && !q->ok &&
	       !memcmp(q->t.rep.f.data, "\xB3\0\0\0\0\0\0", 8);
}

int rmdctl_run_restore(struct dev *d, int argc, char **argv)
{
	/* per motor at most: a change a gain (V4), acceleration, zero offset, comm-loss time */
	static struct change ch[(RMD_PID_SLOTS_MAX + 3) * RMD_MAX_MOTORS];
	static struct file f;
	unsigned n = 0, bad_writes = 0, motors_changed = 0;
	int r;

	(void)argc;
	memset(&f, 0, sizeof(f));
	f.path = argv[0];
	f.dl = rmdctl_dialect(d);
	r = dialect_ok(d);
	if (r)
		return r;
	if (parse_file(&f) < 0)
		return RMDCTL_EXIT_DATA;
	if (f.bus[0] && strcmp(f.bus, d->name))
		tool_log(TOOL_LOG_WARNING, "%s: dumped from %s, restored to %s", f.path, f.bus,
			 d->name);
	/* one layout's gains mean nothing in another's (V3 §2.1 uint8, V4.2 §2.1 float) */
	if (f.dl->table != rmdctl_dialect(d)->table) {
		if (!d->force) {
			tool_log(
				TOOL_LOG_ERR,
				"%s: dumped from protocol %s motors, these are %s (--protocol %s): "
				"their gains do not translate; --force writes all but the gains",
				f.path, f.dl->key, rmdctl_dialect(d)->key, rmdctl_dialect(d)->key);
			return RMDCTL_EXIT_USAGE;
		}
		tool_log(TOOL_LOG_WARNING, "%s: protocol %s, motors %s: the gains are not written",
			 f.path, f.dl->key, rmdctl_dialect(d)->key);
		for (unsigned i = 0; i < f.n; i++)
			f.motor[i].has_pid = false;
	}
	r = rmdctl_open_bus(d);
	if (r)
		return r;
	for (unsigned i = 0; i < f.n; i++) {
		struct settings now = { .id = f.motor[i].id };
		unsigned k;

		r = read_settings(d, &now, NULL);
		if (r) {
			tool_log(TOOL_LOG_ERR,
				 "%s:%u: motor %u: cannot read its settings: nothing "
				 "written",
				 f.path, f.motor[i].line, now.id);
			goto out;
		}
		k = diff(rmdctl_dialect(d), &f.motor[i], &now, &ch[n]);
		if (!k)
			printf("%s: motor %u: unchanged\n", d->name, now.id);
		for (unsigned j = 0; j < k; j++)
			printf("%s: motor %u: %s\n", d->name, now.id, ch[n + j].text);
		motors_changed += k > 0;
		n += k;
	}
	if (!n) {
		printf("%s: nothing to write: every motor has the settings of %s\n", d->name,
		       f.path);
		goto out;
	}
	fflush(stdout);
	r = rmdctl_confirm(d, "write %s %u change%s to %u motor%s on %s (ROM)",
			   n == 1 ? "this" : "these", n, n == 1 ? "" : "s", motors_changed,
			   motors_changed == 1 ? "" : "s", d->name);
	if (r)
		goto out;
	for (unsigned i = 0; i < n; i++) {
		r = rmdctl_run_reqs(d, &ch[i].q, 1);
		if (r)
			goto out;
		if (b3_zeros(&ch[i].q))
			continue;
		if (rmdctl_ask_check(d, &ch[i].q)) {
			tool_log(TOOL_LOG_ERR, "%s: motor %u: %s: not written", d->name, ch[i].id,
				 ch[i].text);
			bad_writes++;
		}
	}
	if (bad_writes) {
		r = RMDCTL_EXIT_DATA;
		goto out;
	}
	printf("%s: %u change%s to %u motor%s written to ROM, each answered\n", d->name, n,
	       n == 1 ? "" : "s", motors_changed, motors_changed == 1 ? "" : "s");
out:
	rmdctl_close_bus(d);
	return r;
}
