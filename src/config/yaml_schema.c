// SPDX-License-Identifier: MIT
/*
 * The generic half of the YAML loader (yaml_schema.h): document tree,
 * schema walker, error collector.  Non-rt.
 *
 * 1. libyaml's event parser builds a small tree of the document whose
 *    nodes keep their line numbers (rmd_yaml_tree_load).  A syntax error is
 *    reported with the key path of the node being parsed.
 * 2. The tree is walked against schema tables (struct field): each key is
 *    looked up, its value converted, range checked and stored at its
 *    offset in the target struct; unknown and duplicate keys are refused,
 *    with the nearest allowed key when one is close.
 *
 * libcyaml (schema-driven too) was the other candidate: its 1.3 loader
 * keeps no positions for the values it stores and has no ranges or
 * defaults, so checks after the load could not name a line.
 */
#include <errno.h>
#include <inttypes.h>
#include <math.h>
#include <stdarg.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <strings.h>

#include <yaml.h>

#include "rmd/err.h"
#include "yaml_schema.h"

#define MAX_ERRORS 32 /* error lines kept in err */
#define MAX_DEPTH 32  /* YAML nesting refused beyond this */

__attribute__((format(printf, 4, 5))) void rmd_yaml_report(struct yctx *c, unsigned line,
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

void rmd_yaml_tree_free(struct ytree *t)
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

bool rmd_yaml_capped(const struct yctx *c)
{
	return c->nerr > MAX_ERRORS;
}

/* A limit of the tree reached at `line`: report it with the parser's place. */
static int tree_refuse(struct yctx *c, struct ynode *const *stack, unsigned depth, unsigned line,
		       const char *what)
{
	char path[PATH_LEN];

	stack_path(stack, depth, path, sizeof(path));
	rmd_yaml_report(c, line, path, "%s", what);
	return -EINVAL;
}

/* anchor_add() failed with r: -E2BIG is the anchor limit, reported; -ENOMEM is returned. */
static int anchor_refuse(struct yctx *c, struct ynode *const *stack, unsigned depth, unsigned line,
			 int r)
{
	char what[128];

	if (r != -E2BIG)
		return r;
	snprintf(what, sizeof(what), "more than %d anchors (&name): rmdd keeps at most %d",
		 MAX_ANCHORS, MAX_ANCHORS);
	return tree_refuse(c, stack, depth, line, what);
}

/*
 * Parse the file's text buf[len] into t.  Returns 0, or -EINVAL after
 * reporting a syntax error, a NUL in a scalar or a limit, or -ENOMEM.
 */
int rmd_yaml_tree_load(struct yctx *c, const char *buf, size_t len, struct ytree *t)
{
	struct ynode *stack[MAX_DEPTH];
	unsigned depth = 0, docs = 0;
	yaml_parser_t p;
	yaml_event_t ev;
	int ret = 0;
	bool done = false;

	if (!yaml_parser_initialize(&p))
		return -ENOMEM;
	yaml_parser_set_input_string(&p, (const unsigned char *)buf, len);
	while (!done) {
		struct ynode *node = NULL;
		unsigned line;
		int r;

		if (!yaml_parser_parse(&p, &ev)) {
			char path[PATH_LEN];

			stack_path(stack, depth, path, sizeof(path));
			if (p.context)
				rmd_yaml_report(c, (unsigned)p.problem_mark.line + 1, path,
						"syntax error: %s (%s at line %u)", p.problem,
						p.context, (unsigned)p.context_mark.line + 1);
			else
				rmd_yaml_report(c, (unsigned)p.problem_mark.line + 1, path,
						"syntax error: %s",
						p.problem ? p.problem : "unreadable input");
			ret = -EINVAL;
			break;
		}
		line = (unsigned)ev.start_mark.line + 1;
		if ((ev.type == YAML_ALIAS_EVENT || ev.type == YAML_SCALAR_EVENT ||
		     ev.type == YAML_SEQUENCE_START_EVENT || ev.type == YAML_MAPPING_START_EVENT) &&
		    ++t->n_nodes > MAX_NODES) {
			char what[160];

			snprintf(what, sizeof(what),
				 "more than %u keys, values and entries: a configuration file has "
				 "a few thousand",
				 MAX_NODES);
			ret = tree_refuse(c, stack, depth, line, what);
			yaml_event_delete(&ev);
			break;
		}
		if (ev.type == YAML_SCALAR_EVENT &&
		    memchr(ev.data.scalar.value, '\0', ev.data.scalar.length)) {
			ret = tree_refuse(c, stack, depth, line,
					  "the value contains a NUL character (\\0): text values "
					  "cannot hold one");
			yaml_event_delete(&ev);
			break;
		}
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
				rmd_yaml_report(c, line, "",
						"a second YAML document: the file holds one");
				ret = -EINVAL;
				done = true;
			}
			break;
		case YAML_ALIAS_EVENT:
			node = anchor_find(t, ev.data.alias.anchor);
			if (!node || node->open) {
				char path[PATH_LEN];

				stack_path(stack, depth, path, sizeof(path));
				rmd_yaml_report(c, line, path,
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
			if (!node->str)
				node = NULL;
			else if ((r = anchor_add(t, ev.data.scalar.anchor, node)) < 0)
				node = NULL, ret = anchor_refuse(c, stack, depth, line, r);
			break;
		case YAML_SEQUENCE_START_EVENT:
		case YAML_MAPPING_START_EVENT:
			node = node_new(t, ev.type == YAML_SEQUENCE_START_EVENT ? Y_SEQ : Y_MAP,
					line);
			if (!node)
				break;
			node->open = true;
			r = anchor_add(t,
				       ev.type == YAML_SEQUENCE_START_EVENT ?
					       ev.data.sequence_start.anchor :
					       ev.data.mapping_start.anchor,
				       node);
			if (r < 0)
				node = NULL, ret = anchor_refuse(c, stack, depth, line, r);
			break;
		case YAML_SEQUENCE_END_EVENT:
		case YAML_MAPPING_END_EVENT:
			if (depth > 0)
				stack[--depth]->open = false;
			break;
		}
		if (ret)
			done = true;
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
					rmd_yaml_report(c, line, "", "nested deeper than %d levels",
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
const struct ynode *rmd_yaml_get(const struct ynode *m, const char *key, unsigned *key_line)
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
unsigned rmd_yaml_line_of(const struct ynode *m, const char *key)
{
	const struct ynode *v = rmd_yaml_get(m, key, NULL);

	return v ? v->line : (m ? m->line : 1);
}

bool rmd_yaml_is_null(const struct ynode *n)
{
	return n->kind == Y_SCALAR && n->plain &&
	       (!n->str[0] || !strcmp(n->str, "~") || !strcasecmp(n->str, "null"));
}

const char *rmd_yaml_kind_desc(const struct ynode *n)
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
/* Walking the tree against the schema */

/* path.key and path[i]; a path too long for PATH_LEN is cut. */
void rmd_yaml_path_key(char *out, const char *path, const char *key)
{
	if (snprintf(out, PATH_LEN, "%s%s%s", path, *path ? "." : "", key) >= PATH_LEN)
		out[PATH_LEN - 1] = '\0';
}

void rmd_yaml_path_idx(char *out, const char *path, unsigned i)
{
	if (snprintf(out, PATH_LEN, "%s[%u]", path, i) >= PATH_LEN)
		out[PATH_LEN - 1] = '\0';
}

/* "a, b, c" of a NULL-terminated list, or of a field table's keys. */
void rmd_yaml_join_names(char *out, size_t len, const char *const *names,
			 const struct field *fields)
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

/* A signed field holds the same two's-complement bits as its unsigned twin. */
static void store_int(void *dst, size_t size, int64_t v)
{
	store_uint(dst, size, (uint64_t)v);
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
	else if (f->type == T_UINT)
		/* a double max of 2^64 - 1 is 2^64: print the u64 it stands for */
		snprintf(out, len, "%" PRIu64 "..%" PRIu64, (uint64_t)f->min,
			 f->max >= 0x1p64 ? UINT64_MAX : (uint64_t)f->max);
	else if (f->type == T_INT)
		snprintf(out, len, "%.0f..%.0f", f->min, f->max);
	else
		snprintf(out, len, "%g..%g", f->min, f->max);
}

static void range_error(struct yctx *c, const struct ynode *v, const struct field *f,
			const char *path)
{
	char r[96];

	range_str(r, sizeof(r), f);
	if (f->why)
		rmd_yaml_report(c, v->line, path, "%s is out of range (%s): %s", v->str, r, f->why);
	else
		rmd_yaml_report(c, v->line, path, "%s is out of range (%s)", v->str, r);
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

void rmd_yaml_walk_value(struct yctx *c, const struct ynode *v, const struct field *f, void *dst,
			 const char *path)
{
	char names[512];

	if (f->type == T_LATER)
		return;
	if (f->type == T_MAP) {
		if (rmd_yaml_is_null(v))
			return;
		if (v->kind != Y_MAP) {
			rmd_yaml_join_names(names, sizeof(names), NULL, f->sub);
			rmd_yaml_report(c, v->line, path, "expected a mapping (keys %s), got %s",
					names, rmd_yaml_kind_desc(v));
			return;
		}
		rmd_yaml_walk_map(c, v, f->sub, dst, path);
		return;
	}
	if (f->type == T_SEQ) {
		unsigned n = 0, before;
		char ip[PATH_LEN];

		if (!rmd_yaml_is_null(v) && v->kind != Y_SEQ) {
			rmd_yaml_report(c, v->line, path, "expected a sequence (a list), got %s",
					rmd_yaml_kind_desc(v));
			return;
		}
		for (unsigned i = 0; !rmd_yaml_is_null(v) && i < v->n && !rmd_yaml_capped(c); i++) {
			char *el = (char *)dst + n * f->elem_size;

			if (n == f->size) {
				rmd_yaml_report(c, v->kids[i]->line, path,
						"%u entries, at most %zu allowed", v->n, f->size);
				break;
			}
			if (f->init)
				f->init(el);
			rmd_yaml_path_idx(ip, path, i);
			before = c->nerr;
			rmd_yaml_walk_value(c, v->kids[i], f->elem, el, ip);
			if (c->nerr != before && f->mark)
				c->bad[f->mark - 1] |= 1u << n;
			n++;
		}
		/* dst is the array; the count lives at count_off of the parent */
		memcpy((char *)dst - f->off + f->count_off, &n, sizeof(n));
		return;
	}
	/* scalars */
	if (v->kind != Y_SCALAR) {
		rmd_yaml_report(c, v->line, path, "expected a single value, got %s",
				rmd_yaml_kind_desc(v));
		return;
	}
	if (rmd_yaml_is_null(v)) {
		rmd_yaml_report(c, v->line, path, "a value is required");
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
			rmd_yaml_report(c, v->line, path, "expected an integer, got \"%s\"",
					v->str);
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
			rmd_yaml_report(c, v->line, path,
					"%s is not allowed: a finite number is required", v->str);
			return;
		}
		errno = 0;
		d = v->plain ? strtod(v->str, &end) : 0.0;
		if (!v->plain || end == v->str || *end != '\0') {
			rmd_yaml_report(c, v->line, path, "expected a number, got \"%s\"", v->str);
			return;
		}
		if (errno == ERANGE && fabs(d) > 1.0) {
			rmd_yaml_report(c, v->line, path,
					"%s is too large: a finite number is required", v->str);
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
			rmd_yaml_report(c, v->line, path, "expected true or false, got \"%s\"",
					v->str);
			return;
		}
		memcpy(dst, &b, sizeof(b));
		return;
	}
	case T_STR: {
		size_t len = strlen(v->str);

		if (len >= f->size) {
			rmd_yaml_report(c, v->line, path,
					"\"%s\" is too long (at most %zu characters)", v->str,
					f->size - 1);
			return;
		}
		if (f->flags & F_IDENT) {
			if (!len ||
			    strspn(v->str, "abcdefghijklmnopqrstuvwxyz0123456789_") != len) {
				rmd_yaml_report(
					c, v->line, path,
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
		rmd_yaml_join_names(names, sizeof(names), f->names, NULL);
		rmd_yaml_report(c, v->line, path, "\"%s\" is not one of %s", v->str, names);
		return;
	case T_TEXT: {
		char allowed[256];

		if (f->parse(f, v->str, dst, allowed, sizeof(allowed)) < 0)
			rmd_yaml_report(c, v->line, path, "\"%s\": expected %s", v->str, allowed);
		return;
	}
	case T_MAP:
	case T_SEQ:
	case T_LATER:
		break;
	}
}

/* The allowed key closest to a misspelt one (at most 2 edits), or NULL. */
static const char *nearest_key(const char *key, const struct field *fields)
{
	const char *best = NULL;
	unsigned best_d = 3;

	for (unsigned j = 0; fields[j].key; j++) {
		unsigned d = rmd_edit_distance(key, fields[j].key);

		if (d < best_d) {
			best_d = d;
			best = fields[j].key;
		}
	}
	return best;
}

/* A key of a map and its place, for finding duplicates. */
struct key_at {
	const struct ynode *key;
	unsigned idx;
};

static int cmp_key(const void *a, const void *b)
{
	const struct key_at *x = a, *y = b;
	int r = strcmp(x->key->str, y->key->str);

	return r ? r : (x->idx > y->idx) - (x->idx < y->idx);
}

/*
 * first[i]: the first key of map m equal to its i-th key, or NULL when that
 * key is the first (or not a scalar).  Sorting keeps it O(n log n) for a
 * map of 100 000 keys.  Returns NULL (no duplicates, or out of memory,
 * then reported) or an array to free.
 */
static const struct ynode **find_duplicates(struct yctx *c, const struct ynode *m)
{
	unsigned nk = m->n / 2, ns = 0;
	const struct ynode **first;
	struct key_at *sorted;
	bool any = false;

	if (nk < 2)
		return NULL;
	sorted = malloc(nk * sizeof(*sorted));
	first = calloc(nk, sizeof(*first));
	if (!sorted || !first) {
		rmd_yaml_report(c, m->line, "", "out of memory");
		free(sorted);
		free(first);
		return NULL;
	}
	for (unsigned i = 0; i < nk; i++)
		if (m->kids[2 * i]->kind == Y_SCALAR)
			sorted[ns++] = (struct key_at){ m->kids[2 * i], i };
	qsort(sorted, ns, sizeof(*sorted), cmp_key);
	for (unsigned i = 1, g = 0; i < ns; i++) {
		if (strcmp(sorted[i].key->str, sorted[g].key->str)) {
			g = i; /* a new group; its first in document order */
			continue;
		}
		first[sorted[i].idx] = sorted[g].key;
		any = true;
	}
	free(sorted);
	if (!any) {
		free(first);
		return NULL;
	}
	return first;
}

void rmd_yaml_walk_map(struct yctx *c, const struct ynode *m, const struct field *fields,
		       void *base, const char *path)
{
	char kp[PATH_LEN], names[512];
	const struct ynode **dup = rmd_yaml_capped(c) ? NULL : find_duplicates(c, m);

	for (unsigned i = 0; i + 1 < m->n && !rmd_yaml_capped(c); i += 2) {
		const struct ynode *k = m->kids[i], *v = m->kids[i + 1];
		const struct field *f = NULL;

		if (k->kind != Y_SCALAR) {
			rmd_yaml_report(c, k->line, path, "a key must be a plain name, got %s",
					rmd_yaml_kind_desc(k));
			continue;
		}
		rmd_yaml_path_key(kp, path, k->str);
		if (dup && dup[i / 2]) {
			rmd_yaml_report(c, k->line, kp, "duplicate key (first at line %u)",
					dup[i / 2]->line);
			continue;
		}
		for (unsigned j = 0; fields[j].key; j++)
			if (!strcmp(fields[j].key, k->str))
				f = &fields[j];
		if (!f) {
			const char *near = nearest_key(k->str, fields);

			rmd_yaml_join_names(names, sizeof(names), NULL, fields);
			if (near)
				rmd_yaml_report(c, k->line, kp,
						"unknown key (did you mean %s?); allowed: %s", near,
						names);
			else
				rmd_yaml_report(c, k->line, kp, "unknown key; allowed: %s", names);
			continue;
		}
		rmd_yaml_walk_value(c, v, f, (char *)base + f->off, kp);
	}
	free(dup);
	for (unsigned j = 0; fields[j].key && !rmd_yaml_capped(c); j++) {
		if ((fields[j].flags & F_REQUIRED) && !rmd_yaml_get(m, fields[j].key, NULL)) {
			rmd_yaml_path_key(kp, path, fields[j].key);
			rmd_yaml_report(c, m->line, kp, "required key missing");
		}
	}
}

/* ------------------------------------------------------------------ */
/* The tables as JSON Schema (draft-07), for YAML editors */

static void json_str(FILE *out, const char *s)
{
	fputc('"', out);
	for (; *s; s++) {
		unsigned char ch = (unsigned char)*s;

		if (ch == '"' || ch == '\\')
			fprintf(out, "\\%c", ch);
		else if (ch < 0x20)
			fprintf(out, "\\u%04x", ch);
		else
			fputc(ch, out);
	}
	fputc('"', out);
}

static void json_schema_value(FILE *out, const struct field *table, const struct field *f,
			      rmd_yaml_later_fn later, unsigned ind);

/* A T_MAP's members: "type": object, its properties, required keys, no others. */
static void json_schema_map(FILE *out, const struct field *sub, rmd_yaml_later_fn later,
			    unsigned ind)
{
	bool first = true;

	/* an empty (null) section means its defaults, as the loader takes it */
	fprintf(out, "\"type\": [\"object\", \"null\"],\n%*s\"additionalProperties\": false,\n",
		ind, "");
	fprintf(out, "%*s\"properties\": {", ind, "");
	for (const struct field *k = sub; k->key; k++) {
		fprintf(out, "%s\n%*s", first ? "" : ",", ind + 2, "");
		json_str(out, k->key);
		fprintf(out, ": {");
		json_schema_value(out, sub, k, later, ind + 4);
		fprintf(out, "\n%*s}", ind + 2, "");
		first = false;
	}
	fprintf(out, "\n%*s}", ind, "");
	first = true;
	for (const struct field *k = sub; k->key; k++) {
		if (!(k->flags & F_REQUIRED))
			continue;
		fprintf(out, first ? ",\n%*s\"required\": [" : ", ", ind, "");
		json_str(out, k->key);
		first = false;
	}
	if (!first)
		fputc(']', out);
}

/* "minimum"/"maximum" of a number, as rmd_yaml_walk_value() checks them. */
static void json_schema_range(FILE *out, const struct field *f, unsigned ind)
{
	fprintf(out, ",\n%*s\"%s\": %.17g", ind, "",
		(f->flags & F_MIN_EXCL) ? "exclusiveMinimum" : "minimum", f->min);
	fprintf(out, ",\n%*s\"maximum\": %.17g", ind, "", f->max);
}

/* The members of one value's schema object (without its braces). */
static void json_schema_value(FILE *out, const struct field *table, const struct field *f,
			      rmd_yaml_later_fn later, unsigned ind)
{
	fprintf(out, "\n%*s", ind, "");
	switch (f->type) {
	case T_UINT:
	case T_INT:
		if (f->flags & F_SIGN) {
			fprintf(out, "\"enum\": [-1, 1]");
			return;
		}
		fprintf(out, "\"type\": \"integer\"");
		json_schema_range(out, f, ind);
		return;
	case T_DOUBLE:
	case T_NS:
		fprintf(out, "\"type\": \"number\"");
		json_schema_range(out, f, ind);
		return;
	case T_BOOL:
		fprintf(out, "\"type\": \"boolean\"");
		return;
	case T_STR:
		fprintf(out, "\"type\": \"string\",\n%*s\"maxLength\": %zu", ind, "", f->size - 1);
		if (f->flags & F_IDENT)
			fprintf(out, ",\n%*s\"pattern\": \"^[a-z0-9_]+$\"", ind, "");
		return;
	case T_ENUM:
		fprintf(out, "\"enum\": [");
		for (int i = 0; f->names[i]; i++) {
			fputs(i ? ", " : "", out);
			json_str(out, f->names[i]);
		}
		fputc(']', out);
		return;
	case T_MAP:
		json_schema_map(out, f->sub, later, ind);
		return;
	case T_SEQ:
		fprintf(out,
			"\"type\": [\"array\", \"null\"],\n%*s\"maxItems\": %zu,\n%*s\"items\": {",
			ind, "", f->size, ind, "");
		json_schema_value(out, table, f->elem, later, ind + 2);
		fprintf(out, "\n%*s}", ind, "");
		return;
	case T_TEXT:
		/* its parser decides (a model name, a date): a scalar */
		fprintf(out, "\"type\": [\"string\", \"number\"]");
		return;
	case T_LATER: {
		const struct field *v = later ? later(table, f) : NULL;

		if (v) {
			/* the member's own description, under this key */
			fprintf(out, "\"description\": \"checked with the keys around it\",");
			json_schema_value(out, table, v, later, ind);
		} else {
			fprintf(out, "\"description\": \"checked with the keys around it\"");
		}
		return;
	}
	}
}

int rmd_yaml_schema_json(FILE *out, const char *title, const struct field *fields,
			 rmd_yaml_later_fn later)
{
	fprintf(out,
		"{\n  \"$schema\": \"http://json-schema.org/draft-07/schema#\",\n  \"title\": ");
	json_str(out, title);
	fprintf(out, ",\n  ");
	json_schema_map(out, fields, later, 2);
	fprintf(out, "\n}\n");
	return fflush(out) == 0 && !ferror(out) ? 0 : -EIO;
}
