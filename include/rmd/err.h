/* SPDX-License-Identifier: MIT */
/* Error messages for callers: lower layers do not log, they fill a buffer. */
#ifndef RMD_ERR_H
#define RMD_ERR_H

#include <stddef.h>

/*
 * Format a message into err (when err and len are non-zero) and return
 * ret, so a failure path reads `return rmd_errf(err, len, -ENODEV, ...)`.
 * Non-rt.
 */
__attribute__((format(printf, 4, 5))) int rmd_errf(char *err, size_t len, int ret, const char *fmt,
						   ...);

/*
 * Edit distance of a and b (inserts, deletes, replacements, and two
 * neighbours swapped), for the "did you mean" of messages; 99 when either
 * is longer than 63 characters.
 * Non-rt.
 */
unsigned rmd_edit_distance(const char *a, const char *b);

#endif /* RMD_ERR_H */
