/* SPDX-License-Identifier: MIT */
/*
 * The generic half of rmdd's YAML loader (src/config/yaml_schema.c): a
 * libyaml document as a small tree whose nodes keep their lines, schema
 * tables (struct field) that say where each key's value goes and what it
 * may be, a walker that stores and checks values against them, and the
 * error collector every message goes through ("FILE:LINE: key.path: ...").
 * rmdd's own tables and checks are src/config/config_yaml.c.  Private to
 * the loader; non-rt: allocates while parsing.
 */
#ifndef RMD_YAML_SCHEMA_H
#define RMD_YAML_SCHEMA_H

#include <stdbool.h>
#include <stddef.h>
#include <stdint.h>
#include <stdio.h>

#define PATH_LEN 192	     /* "buses[12].sim.faults[31].probability" */
#define MAX_ANCHORS 64	     /* anchors remembered for aliases */
#define MAX_NODES (1u << 18) /* keys, values, entries and aliases of one file */
#define YAML_MARKS 2	     /* masks of entries with errors (struct yctx.bad) */

/* ---- the document tree ---- */

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
	unsigned n_nodes; /* nodes and aliases, up to MAX_NODES */
};

/* Error collector. */
struct yctx {
	const char *file;
	char *err;
	size_t errlen;
	size_t used;
	unsigned nerr;
	/*
	 * Entries whose own keys had errors, one mask per marked sequence
	 * (struct field.mark): checks across keys skip them.
	 */
	uint32_t bad[YAML_MARKS];
};

/* ---- schema ---- */

enum ftype {
	T_UINT,	  /* unsigned integer of `size` bytes */
	T_INT,	  /* signed integer of `size` bytes (enums are T_ENUM) */
	T_DOUBLE, /* double, finite, stored times `scale` */
	T_NS,	  /* int64_t, the value times `scale` rounded (seconds, us -> ns) */
	T_BOOL,
	T_STR,	 /* char[size], NUL included */
	T_ENUM,	 /* int-sized enum: index into names */
	T_MAP,	 /* the struct at off, members in sub */
	T_SEQ,	 /* array at off of up to `size` elements described by elem */
	T_LATER, /* allowed key, handled by validate_*() */
	T_TEXT	 /* a scalar's text converted by parse(), which says what is allowed */
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
	unsigned mark; /* T_SEQ: 1..YAML_MARKS: entry i with errors sets bit i of bad[mark - 1] */
	/* T_TEXT: 0, or -EINVAL with what is allowed in `allowed`; ctx is the caller's */
	int (*parse)(const struct field *f, const char *text, void *dst, char *allowed,
		     size_t size);
	const void *ctx;
	const char *why; /* appended to a range error */
};

#define SZ(st, m) sizeof(((st *)0)->m)
/* An integer field of type ty (T_UINT or T_INT); w, when not NULL, is appended to a range error */
#define INTEGER(ty, k, st, m, lo, hi, fl, w)                                                  \
	{                                                                                     \
		.key = k, .type = ty, .flags = fl, .off = offsetof(st, m), .size = SZ(st, m), \
		.min = lo, .max = hi, .why = w                                                \
	}
#define UINT(k, st, m, lo, hi, fl) INTEGER(T_UINT, k, st, m, lo, hi, fl, NULL)
#define UINTW(k, st, m, lo, hi, w) INTEGER(T_UINT, k, st, m, lo, hi, 0, w)
#define INT(k, st, m, lo, hi, fl) INTEGER(T_INT, k, st, m, lo, hi, fl, NULL)
/* scale sc: 0 means 1 */
#define DBLS(k, st, m, lo, hi, fl, sc)                                                      \
	{                                                                                   \
		.key = k, .type = T_DOUBLE, .flags = fl, .off = offsetof(st, m), .min = lo, \
		.max = hi, .scale = sc                                                      \
	}
#define DBL(k, st, m, lo, hi, fl) DBLS(k, st, m, lo, hi, fl, 0)
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

/* ---- functions ---- */

/*
 * Report one error as "FILE:LINE: PATH: message" (LINE 0: none; PATH "": none)
 * into c->err, up to a few dozen lines, then "more errors not shown".
 */
__attribute__((format(printf, 4, 5))) void rmd_yaml_report(struct yctx *c, unsigned line,
							   const char *path, const char *fmt, ...);

/*
 * Parse the file's text buf[len] into t.  Returns 0, or -EINVAL after
 * reporting a syntax error, a NUL in a scalar or a limit (MAX_NODES,
 * MAX_ANCHORS), or -ENOMEM.
 */
int rmd_yaml_tree_load(struct yctx *c, const char *buf, size_t len, struct ytree *t);

/* True once the error collector is full: walkers stop there. */
bool rmd_yaml_capped(const struct yctx *c);
void rmd_yaml_tree_free(struct ytree *t);

/* The value of `key` in map m (NULL if absent, or m is not a map), and the key's line. */
const struct ynode *rmd_yaml_get(const struct ynode *m, const char *key, unsigned *key_line);

/* Line of key's value in m, or of m when the key is absent. */
unsigned rmd_yaml_line_of(const struct ynode *m, const char *key);

bool rmd_yaml_is_null(const struct ynode *n);

/* "a scalar", "a mapping", "a sequence". */
const char *rmd_yaml_kind_desc(const struct ynode *n);

/* path.key and path[i] into out[PATH_LEN]; a path too long is cut. */
void rmd_yaml_path_key(char *out, const char *path, const char *key);
void rmd_yaml_path_idx(char *out, const char *path, unsigned i);

/* "a, b, c" of a NULL-terminated list, or of a field table's keys. */
void rmd_yaml_join_names(char *out, size_t len, const char *const *names,
			 const struct field *fields);

/*
 * Store map m's values at base + each field's off, checking each key, its
 * type and range; unknown, duplicate and missing required keys are
 * reported under `path`.
 */
void rmd_yaml_walk_map(struct yctx *c, const struct ynode *m, const struct field *fields,
		       void *base, const char *path);

/* One value v described by f into dst (for a T_SEQ: the array). */
void rmd_yaml_walk_value(struct yctx *c, const struct ynode *v, const struct field *f, void *dst,
			 const char *path);

/*
 * What a T_LATER key holds, for the JSON Schema: the field that describes
 * its value (a T_STR, a T_MAP, ...), or NULL for any value.  table is the
 * table the key is in.
 */
typedef const struct field *(*rmd_yaml_later_fn)(const struct field *table, const struct field *f);

/*
 * The JSON Schema (draft-07) of a document whose root is the map `fields`:
 * each key with its type, range, names and required keys, unknown keys
 * refused, as rmd_yaml_walk_map() checks them.  What only a cross-key
 * check or a T_TEXT parser refuses is not in it.  Returns 0, or -EIO when
 * writing failed.  Non-rt.
 */
int rmd_yaml_schema_json(FILE *out, const char *title, const struct field *fields,
			 rmd_yaml_later_fn later);

#endif /* RMD_YAML_SCHEMA_H */
