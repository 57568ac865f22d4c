// SPDX-License-Identifier: MIT
/*
 * Per-bus lock files (buslock.h): flock(2) on DIR/rmdd-bus-KEY.lock.
 * Non-rt.
 */
#include <errno.h>
#include <fcntl.h>
#include <limits.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/file.h>
#include <sys/stat.h>
#include <unistd.h>

#include "buslock.h"

#define RUN_DIR "/run/rmdd"
#define TMP_DIR "/tmp"

int tool_buslock_key(char *key, size_t size, const char *dev)
{
	char real[PATH_MAX];
	const char *s = dev;
	size_t n;

	if (!dev || !*dev)
		return -EINVAL;
	if (dev[0] == '/' && realpath(dev, real))
		s = real;
	for (n = 0; *s && n + 1 < size; s++, n++)
		key[n] = *s == '/' ? '_' : *s;
	key[n] = '\0';
	return *s ? -EINVAL : 0;
}

/* The directories to look in, in order: $RMD_LOCK_DIR alone, else /run/rmdd and /tmp. */
static unsigned lock_dirs(const char *dirs[2])
{
	const char *env = getenv("RMD_LOCK_DIR");

	if (env && *env) {
		dirs[0] = env;
		return 1;
	}
	dirs[0] = RUN_DIR;
	dirs[1] = TMP_DIR;
	return 2;
}

/* The pid written in an open lock file, 0 when none. */
static pid_t read_owner(int fd)
{
	char buf[32];
	ssize_t n = pread(fd, buf, sizeof(buf) - 1, 0);

	if (n <= 0)
		return 0;
	buf[n] = '\0';
	return (pid_t)strtol(buf, NULL, 10);
}

int tool_buslock_take(const char *key, int *fd, char *path, size_t psize, pid_t *owner)
{
	const char *dirs[2];
	unsigned n = lock_dirs(dirs);
	char pid[32];
	int r = -ENOENT;

	*fd = -1;
	*owner = 0;
	/* /run/rmdd: systemd's RuntimeDirectory=, or made here when root. */
	if (n == 2)
		(void)mkdir(RUN_DIR, 0755);
	for (unsigned i = 0; i < n; i++) {
		snprintf(path, psize, "%s/rmdd-bus-%s.lock", dirs[i], key);
		*fd = open(path, O_RDWR | O_CREAT | O_CLOEXEC | O_NOFOLLOW, 0644);
		if (*fd < 0) {
			r = -errno;
			continue;
		}
		if (flock(*fd, LOCK_EX | LOCK_NB) < 0) {
			r = errno == EWOULDBLOCK ? -EBUSY : -errno;
			*owner = read_owner(*fd);
			close(*fd);
			*fd = -1;
			return r;
		}
		snprintf(pid, sizeof(pid), "%ld\n", (long)getpid());
		/* The pid is for messages only: the lock holds without it. */
		if (ftruncate(*fd, 0) == 0 && pwrite(*fd, pid, strlen(pid), 0) < 0)
			*owner = 0;
		return 0;
	}
	return r;
}

void tool_buslock_release(int *fd)
{
	/*
	 * The file stays: unlinking it would let a process that opened it just
	 * before lock it while another creates a new one.  A file without a
	 * lock is no owner.
	 */
	if (*fd >= 0)
		close(*fd);
	*fd = -1;
}

bool tool_buslock_held(const char *key, char *path, size_t psize, pid_t *owner)
{
	const char *dirs[2];
	unsigned n = lock_dirs(dirs);

	*owner = 0;
	for (unsigned i = 0; i < n; i++) {
		int fd;
		bool held;

		snprintf(path, psize, "%s/rmdd-bus-%s.lock", dirs[i], key);
		fd = open(path, O_RDONLY | O_CLOEXEC | O_NOFOLLOW);
		if (fd < 0)
			continue;
		/* rmdd holds LOCK_EX: a shared lock is refused while it runs. */
		held = flock(fd, LOCK_SH | LOCK_NB) < 0 && errno == EWOULDBLOCK;
		if (held)
			*owner = read_owner(fd);
		close(fd);
		if (held)
			return true;
	}
	return false;
}
