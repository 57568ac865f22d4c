/* SPDX-License-Identifier: MIT */
/*
 * Reading rmdctl's JSON lines (one object per line, flat) without a JSON
 * library: enough to pick a value by key.  The getters fail the test when
 * the key is missing.
 */
#ifndef RMD_TESTS_JSON_H
#define RMD_TESTS_JSON_H

#include <stdbool.h>
#include <stddef.h>

/* Just past "key": in line, or NULL. */
const char *json_at(const char *line, const char *key);

double json_num(const char *line, const char *key);
bool json_bool(const char *line, const char *key);

/* The string value of key, unescaped no further, into out. */
void json_str(const char *line, const char *key, char *out, size_t len);

/* The n-th (0-based) line of text starting with '{', into line; false when none. */
bool json_line(const char *text, unsigned n, char *line, size_t len);

#endif /* RMD_TESTS_JSON_H */
