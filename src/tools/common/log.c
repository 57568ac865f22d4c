// SPDX-License-Identifier: MIT
/*
 * The programs' logger (log.h): formats a whole line, then writes it with
 * one write(2).  Non-rt.
 */
#include <errno.h>
#include <stdarg.h>
#include <stdio.h>
#include <stdlib.h>
#include <unistd.h>

#include <sys/stat.h>

#include "log.h"

#define LINE_MAX_LEN 2048

static const char *log_name;
static int log_level = TOOL_LOG_INFO;
static unsigned log_flags;

bool tool_log_to_journal(void)
{
	const char *env = getenv("JOURNAL_STREAM");
	unsigned long long dev, ino;
	struct stat st;
	char extra;

	/* systemd.exec(5): "DEVICE:INODE" of the stream journald reads. */
	if (!env || sscanf(env, "%llu:%llu%c", &dev, &ino, &extra) != 2)
		return false;
	if (fstat(STDERR_FILENO, &st) < 0)
		return false;
	return (unsigned long long)st.st_dev == dev && (unsigned long long)st.st_ino == ino;
}

void tool_log_init(const char *name, int max_level, unsigned flags)
{
	log_name = name;
	log_level = max_level;
	log_flags = flags;
	if (!tool_log_to_journal())
		log_flags |= TOOL_LOG_NO_LEVEL;
}

void tool_log_set_level(int max_level)
{
	log_level = max_level;
}

bool tool_log_enabled(int level)
{
	return level <= log_level;
}

__attribute__((format(printf, 2, 0))) static void vlog(int level, const char *fmt, va_list ap)
{
	char buf[LINE_MAX_LEN];
	size_t n = 0;
	int m;

	if (!(log_flags & TOOL_LOG_NO_LEVEL))
		n += (size_t)snprintf(buf, sizeof(buf), "<%d>", level);
	if (log_name)
		n += (size_t)snprintf(buf + n, sizeof(buf) - n, "%s: ", log_name);
	if (n > sizeof(buf) - 2)
		n = sizeof(buf) - 2;
	m = vsnprintf(buf + n, sizeof(buf) - n - 1, fmt, ap);
	if (m < 0)
		return;
	n += (size_t)m;
	if (n > sizeof(buf) - 2)
		n = sizeof(buf) - 2;
	buf[n++] = '\n';
	/* One write per line: lines of concurrent writers do not interleave. */
	while (n > 0) {
		ssize_t w = write(STDERR_FILENO, buf, n);

		if (w < 0 && errno == EINTR)
			continue;
		break;
	}
}

void tool_vlog(int level, const char *fmt, va_list ap)
{
	if (level <= log_level)
		vlog(level, fmt, ap);
}

void tool_log(int level, const char *fmt, ...)
{
	va_list ap;

	va_start(ap, fmt);
	tool_vlog(level, fmt, ap);
	va_end(ap);
}

void tool_log_always(int level, const char *fmt, ...)
{
	va_list ap;

	va_start(ap, fmt);
	vlog(level, fmt, ap);
	va_end(ap);
}
