// SPDX-License-Identifier: MIT
#include <stdarg.h>
#include <stdio.h>
#include <string.h>

#include "rmd/err.h"

int rmd_errf(char *err, size_t len, int ret, const char *fmt, ...)
{
	va_list ap;

	if (err && len) {
		va_start(ap, fmt);
		vsnprintf(err, len, fmt, ap);
		va_end(ap);
	}
	return ret;
}

unsigned rmd_edit_distance(const char *a, const char *b)
{
	unsigned rows[3][64], *prev2 = rows[0], *prev = rows[1], *row = rows[2];
	unsigned n = (unsigned)strlen(b), m = (unsigned)strlen(a);

	if (n > 63 || m > 63)
		return 99;
	for (unsigned j = 0; j <= n; j++)
		prev[j] = j;
	for (unsigned i = 1; i <= m; i++) {
		unsigned *t;

		row[0] = i;
		for (unsigned j = 1; j <= n; j++) {
			unsigned best = prev[j - 1] + (a[i - 1] != b[j - 1]);

			if (prev[j] + 1 < best)
				best = prev[j] + 1;
			if (row[j - 1] + 1 < best)
				best = row[j - 1] + 1;
			/* two neighbours swapped ("stauts") is one slip */
			if (i > 1 && j > 1 && a[i - 1] == b[j - 2] && a[i - 2] == b[j - 1] &&
			    prev2[j - 2] + 1 < best)
				best = prev2[j - 2] + 1;
			row[j] = best;
		}
		t = prev2;
		prev2 = prev;
		prev = row;
		row = t;
	}
	return prev[n];
}
