/* SPDX-License-Identifier: MIT */
/*
 * The one logger of rmdd, rmd-sim and rmdctl: one line per call on stderr,
 * in one write(2), so lines of concurrent threads never mix.
 *
 *   "<N>rmdd: message"   rmdd: syslog level prefix (STYLE.md), then the name
 *   "<N>message"         rmd-sim: name NULL (its messages carry "rmd-sim: ")
 *   "rmdctl scan: message"  rmdctl: TOOL_LOG_NO_LEVEL, for a terminal
 *
 * The "<N>" prefix is written only when journald reads stderr (systemd
 * sets JOURNAL_STREAM to its device and inode): on a terminal, a pipe or a
 * file the lines are plain text.
 *
 * Each program sets its name and verbosity once with tool_log_init().
 * Non-rt.
 */
#ifndef RMD_TOOL_LOG_H
#define RMD_TOOL_LOG_H

#include <stdarg.h>
#include <stdbool.h>

/* Log levels: the journal's <N> prefixes (sd-daemon(3)). */
enum {
	TOOL_LOG_ERR = 3,
	TOOL_LOG_WARNING = 4,
	TOOL_LOG_NOTICE = 5,
	TOOL_LOG_INFO = 6,
	TOOL_LOG_DEBUG = 7,
};

/* tool_log_init() flags */
enum {
	TOOL_LOG_NO_LEVEL = 1u << 0, /* no "<N>" prefix */
};

/* True when journald reads stderr: JOURNAL_STREAM names its device and inode. */
bool tool_log_to_journal(void);

/*
 * name: printed as "name: " after the level prefix (NULL: nothing; the
 * string must outlive the logging); max_level: the most verbose level that
 * tool_log() prints; flags: TOOL_LOG_NO_LEVEL, which tool_log_init() adds
 * unless tool_log_to_journal().  Until called: no name, level 6, "<N>"
 * prefixes.
 */
void tool_log_init(const char *name, int max_level, unsigned flags);

/* Change the most verbose level printed (-v, -q). */
void tool_log_set_level(int max_level);

/* True when tool_log(level, ...) prints. */
bool tool_log_enabled(int level);

/* One line, when level <= the level set. */
void tool_log(int level, const char *fmt, ...) __attribute__((format(printf, 2, 3)));
/* tool_log() of a va_list (a caller's own variadic helper). */
void tool_vlog(int level, const char *fmt, va_list ap) __attribute__((format(printf, 2, 0)));

/* One line whatever the level set (statistics that were asked for). */
void tool_log_always(int level, const char *fmt, ...) __attribute__((format(printf, 2, 3)));

#endif /* RMD_TOOL_LOG_H */
