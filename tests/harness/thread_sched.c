// SPDX-License-Identifier: MIT
/* How long the machine held one thread off: see thread_sched.h. */
#define _GNU_SOURCE
#include "harness/thread_sched.h"

#include <dirent.h>
#include <errno.h>
#include <inttypes.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

pid_t thread_find(pid_t pid, const char *comm)
{
	char path[64], name[32];
	struct dirent *d;
	pid_t found = -ENOENT;
	DIR *dir;

	snprintf(path, sizeof(path), "/proc/%d/task", (int)pid);
	dir = opendir(path);
	if (!dir)
		return -errno;
	while (found < 0 && (d = readdir(dir))) {
		FILE *f;

		if (d->d_name[0] == '.')
			continue;
		snprintf(path, sizeof(path), "/proc/%d/task/%.16s/comm", (int)pid, d->d_name);
		f = fopen(path, "re");
		if (!f)
			continue;
		if (fgets(name, sizeof(name), f)) {
			name[strcspn(name, "\n")] = '\0';
			if (!strcmp(name, comm))
				found = (pid_t)atoi(d->d_name);
		}
		fclose(f);
	}
	closedir(dir);
	return found;
}

int thread_sched_read(pid_t pid, pid_t tid, struct thread_sched *s)
{
	char path[64];
	FILE *f;
	int n;

	snprintf(path, sizeof(path), "/proc/%d/task/%d/schedstat", (int)pid, (int)tid);
	f = fopen(path, "re");
	if (!f)
		return -errno;
	n = fscanf(f, "%" SCNd64 " %" SCNd64 " %" SCNu64, &s->run_ns, &s->wait_ns, &s->slices);
	fclose(f);
	return n == 3 ? 0 : -EIO;
}

int64_t thread_wait_since(pid_t pid, pid_t tid, const struct thread_sched *since)
{
	struct thread_sched now;

	if (thread_sched_read(pid, tid, &now) < 0)
		return 0;
	return now.wait_ns - since->wait_ns;
}
