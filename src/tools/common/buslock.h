/* SPDX-License-Identifier: MIT */
/*
 * Who owns a bus: rmdd holds an exclusive flock(2) on one lock file per
 * bus it drives, from before it opens the bus until it exits (the kernel
 * drops the lock when the process dies, however it dies: no stale locks).
 * rmdctl's device commands look for a held lock before they send and
 * refuse unless --force.  Only buses with a descriptor (SocketCAN, RS485)
 * are locked: simulated buses live inside one process.
 *
 * The file is DIR/rmdd-bus-KEY.lock and holds the owner's pid (for
 * messages).  KEY is the SocketCAN interface name, or the serial device's
 * resolved path with '/' as '_' (so /dev/serial/by-id/... and /dev/ttyUSB0
 * are one bus).  DIR: $RMD_LOCK_DIR when set; else rmdd takes /run/rmdd
 * (systemd's RuntimeDirectory=rmdd; made when it can) and falls back to
 * /tmp, and rmdctl looks in both.  No network, no daemon needed.  Non-rt.
 */
#ifndef RMD_TOOL_BUSLOCK_H
#define RMD_TOOL_BUSLOCK_H

#include <stdbool.h>
#include <stddef.h>
#include <sys/types.h>

#define TOOL_BUSLOCK_PATH_LEN 512

/*
 * The lock key of a bus: dev is a serial device path (starting with '/',
 * resolved) or an interface name.  0 or -EINVAL.
 */
int tool_buslock_key(char *key, size_t size, const char *dev);

/*
 * rmdd: take bus KEY's lock, kept in *fd until tool_buslock_release().
 * 0; -EBUSY when another process holds it (path and *owner say which:
 * its pid, 0 when unknown); another -errno when no directory takes the file
 * (path: the last one tried).
 */
int tool_buslock_take(const char *key, int *fd, char *path, size_t psize, pid_t *owner);

/* Release a lock taken (closes *fd; -1 is fine). */
void tool_buslock_release(int *fd);

/* rmdctl: true when a process holds bus KEY's lock; path and *owner say which. */
bool tool_buslock_held(const char *key, char *path, size_t psize, pid_t *owner);

#endif /* RMD_TOOL_BUSLOCK_H */
