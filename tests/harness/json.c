// SPDX-License-Identifier: MIT
/* JSON lines by key (json.h). */
#include <setjmp.h>
#include <stdarg.h>
#include <stdbool.h>
#include <stddef.h>
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include <cmocka.h>

#include "harness/json.h"

const char *json_at(const char *line, const char *key)
{
	char pat[64];
	const char *p;

	snprintf(pat, sizeof(pat), "\"%s\":", key);
	p = strstr(line, pat);
	return p ? p + strlen(pat) : NULL;
}

/* The value of key; fails the test when it is missing. */
static const char *json_need(const char *line, const char *key)
{
	const char *p = json_at(line, key);

	if (!p)
		fail_msg("key \"%s\" missing from %s", key, line);
	return p;
}

double json_num(const char *line, const char *key)
{
	return strtod(json_need(line, key), NULL);
}

bool json_bool(const char *line, const char *key)
{
	return !strncmp(json_need(line, key), "true", 4);
}

void json_str(const char *line, const char *key, char *out, size_t len)
{
	const char *p = json_need(line, key);
	size_t n = 0;

	if (*p != '"')
		fail_msg("string \"%s\" missing from %s", key, line);
	for (p++; *p && *p != '"' && n + 1 < len; p++)
		out[n++] = *p;
	out[n] = '\0';
}

bool json_line(const char *text, unsigned n, char *line, size_t len)
{
	for (const char *p = text; p && *p;) {
		const char *nl = strchr(p, '\n');
		size_t l = nl ? (size_t)(nl - p) : strlen(p);

		if (*p == '{' && n-- == 0) {
			snprintf(line, len, "%.*s", (int)l, p);
			return true;
		}
		p = nl ? nl + 1 : NULL;
	}
	return false;
}
