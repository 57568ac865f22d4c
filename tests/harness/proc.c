// SPDX-License-Identifier: MIT
/* Programs as processes (proc.h). */
#define _GNU_SOURCE
#include <dirent.h>
#include <errno.h>
#include <fcntl.h>
#include <poll.h>
#include <sched.h>
#include <setjmp.h>
#include <signal.h>
#include <stdarg.h>
#include <stdbool.h>
#include <stddef.h>
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <time.h>
#include <unistd.h>

#include <sys/prctl.h>
#include <sys/stat.h>
#include <sys/types.h>
#include <sys/wait.h>

#include <cmocka.h>

#include "rmd/time.h"
#include "harness/proc.h"
#include "harness/sleeper.h"

#define NS_PER_MS INT64_C(1000000)
#define RUN_LIMIT_MS 30000
#define ARGS_MAX 64

static struct kid kids[KID_MAX];

static int status_of(int ws)
{
	return WIFEXITED(ws) ? WEXITSTATUS(ws) : 128 + WTERMSIG(ws);
}

int find_prog(char *out, size_t size, const char *env, const char *name)
{
	const char *path = getenv(env), *build = getenv("BUILD");

	if (path && *path)
		snprintf(out, size, "%s", path);
	else
		snprintf(out, size, "%s/%s", build && *build ? build : "build", name);
	if (access(out, X_OK) == 0)
		return 0;
	fprintf(stderr, "%s binary \"%s\": %s (set %s or BUILD)\n", name, out, strerror(errno),
		env);
	return -1;
}

void temp_file(char *path, const char *text)
{
	int fd = mkstemp(path);
	FILE *f;

	if (fd < 0)
		fail_msg("%s: %s", path, strerror(errno));
	f = fdopen(fd, "w");
	assert_non_null(f);
	fputs(text, f);
	assert_int_equal(fclose(f), 0);
}

const char *file_text(const char *path, char *buf, size_t size)
{
	FILE *f = fopen(path, "r");
	size_t n = 0;

	if (f) {
		n = fread(buf, 1, size - 1, f);
		fclose(f);
	}
	buf[n] = '\0';
	return buf;
}

void close_fd(int *fd)
{
	if (*fd >= 0)
		close(*fd);
	*fd = -1;
}

unsigned dir_sorted(const char *dir, const char *first, char names[][DIR_NAME_MAX], unsigned max)
{
	struct dirent **list;
	int n = scandir(dir, &list, NULL, alphasort);
	unsigned got = 0;

	for (int i = 0; i < n; i++) {
		if (list[i]->d_name[0] && strchr(first, list[i]->d_name[0]) && got < max)
			snprintf(names[got++], DIR_NAME_MAX, "%.200s", list[i]->d_name);
		free(list[i]);
	}
	if (n >= 0)
		free(list);
	return got;
}

int rm_tree(const char *dir)
{
	char cmd[1200];

	snprintf(cmd, sizeof(cmd), "rm -rf '%s'", dir);
	return system(cmd) == 0 ? 0 : -1;
}

/* In the child: die with the test, stdin from in_fd, no inherited descriptors. */
static void child_prepare(int in_fd, int out_fd, int err_fd)
{
	prctl(PR_SET_PDEATHSIG, SIGKILL);
	if (in_fd < 0)
		in_fd = open("/dev/null", O_RDONLY);
	if (in_fd >= 0)
		dup2(in_fd, 0);
	dup2(out_fd, 1);
	dup2(err_fd, 2);
	for (int fd = 3; fd < 1024; fd++)
		close(fd);
	signal(SIGPIPE, SIG_DFL);
}

/* argv for exec: path, then args, then NULL. */
static void make_argv(const char **argv, const char *path, const char *const *args)
{
	size_t n = 0;

	argv[n++] = path;
	for (; args && *args && n < ARGS_MAX - 1; args++)
		argv[n++] = *args;
	argv[n] = NULL;
}

pid_t spawn_piped(const char *path, const char *const *args, int *fd,
		  void (*in_child)(const void *ctx), const void *ctx)
{
	const char *argv[ARGS_MAX];
	int pfd[2];
	pid_t pid;

	make_argv(argv, path, args);
	assert_int_equal(pipe2(pfd, O_CLOEXEC), 0);
	pid = fork();
	assert_true(pid >= 0);
	if (pid == 0) {
		child_prepare(-1, pfd[1], pfd[1]);
		if (in_child)
			in_child(ctx);
		execv(path, (char *const *)argv);
		fprintf(stderr, "exec %s: %s\n", path, strerror(errno));
		_exit(127);
	}
	close(pfd[1]);
	*fd = pfd[0];
	return pid;
}

void journal_stream_env(const void *ctx)
{
	struct stat st;
	char v[64];

	(void)ctx;
	if (fstat(STDERR_FILENO, &st) < 0)
		return;
	snprintf(v, sizeof(v), "%llu:%llu", (unsigned long long)st.st_dev,
		 (unsigned long long)st.st_ino);
	setenv("JOURNAL_STREAM", v, 1);
}

pid_t spawn_pty(const char *path, const char *const *args, int *master,
		void (*in_child)(const void *ctx), const void *ctx)
{
	const char *argv[ARGS_MAX];
	int m, s;
	pid_t pid;

	make_argv(argv, path, args);
	m = posix_openpt(O_RDWR | O_NOCTTY | O_CLOEXEC);
	assert_true(m >= 0);
	assert_int_equal(grantpt(m), 0);
	assert_int_equal(unlockpt(m), 0);
	pid = fork();
	assert_true(pid >= 0);
	if (pid == 0) {
		setsid();
		s = open(ptsname(m), O_RDWR); /* the session's controlling terminal */
		if (s < 0)
			_exit(126);
		child_prepare(s, s, s);
		if (in_child)
			in_child(ctx);
		execv(path, (char *const *)argv);
		fprintf(stderr, "exec %s: %s\n", path, strerror(errno));
		_exit(127);
	}
	fcntl(m, F_SETFL, O_NONBLOCK);
	*master = m;
	return pid;
}

/* ---- one run to its end ------------------------------------------------------ */

struct sink {
	int fd; /* -1 at EOF */
	char *buf;
	size_t len, cap;
};

/* Read what is there into s (growing it).  At EOF or error, closes s->fd. */
static void sink_take(struct sink *s)
{
	ssize_t k;

	if (s->len + 4096 >= s->cap) {
		s->cap = s->cap ? 2 * s->cap : 65536;
		s->buf = realloc(s->buf, s->cap);
		assert_non_null(s->buf);
	}
	k = read(s->fd, s->buf + s->len, s->cap - 1 - s->len);
	if (k > 0)
		s->len += (size_t)k;
	else if (k == 0 || (errno != EAGAIN && errno != EINTR)) {
		close(s->fd);
		s->fd = -1;
	}
	s->buf[s->len] = '\0';
}

/* stdin for a run: the input in an unlinked file, or -1 for /dev/null. */
static int input_fd(const struct run_opts *o)
{
	FILE *f;
	int fd;

	if (!o || !o->input)
		return -1;
	f = tmpfile();
	assert_non_null(f);
	if (o->input_len)
		assert_int_equal(fwrite(o->input, 1, o->input_len, f), o->input_len);
	fflush(f);
	fd = dup(fileno(f));
	fclose(f);
	assert_true(fd >= 0);
	lseek(fd, 0, SEEK_SET);
	return fd;
}

void run_prog(struct run *r, const char *path, const char *const *args, const struct run_opts *o)
{
	const char *argv[ARGS_MAX];
	struct sink s[2] = { { .fd = -1 }, { .fd = -1 } };
	int po[2], pe[2], in, ws = 0, limit_ms = o && o->limit_ms ? o->limit_ms : RUN_LIMIT_MS;
	service_fn *service = o ? o->service : NULL;
	int64_t t0 = rmd_now_ns(), end = t0 + limit_ms * NS_PER_MS;
	pid_t pid;

	memset(r, 0, sizeof(*r));
	make_argv(argv, path, args);
	in = input_fd(o);
	assert_int_equal(pipe2(po, O_CLOEXEC), 0);
	assert_int_equal(pipe2(pe, O_CLOEXEC), 0);
	pid = fork();
	assert_true(pid >= 0);
	if (pid == 0) {
		child_prepare(in, po[1], pe[1]);
		if (o && o->unset_env)
			unsetenv(o->unset_env);
		execv(path, (char *const *)argv);
		fprintf(stderr, "exec %s: %s\n", path, strerror(errno));
		_exit(127);
	}
	if (in >= 0)
		close(in);
	close(po[1]);
	close(pe[1]);
	s[0].fd = po[0];
	s[1].fd = pe[0];
	while (s[0].fd >= 0 || s[1].fd >= 0 || waitpid(pid, &ws, WNOHANG) != pid) {
		struct pollfd p[2] = { { .fd = s[0].fd, .events = POLLIN },
				       { .fd = s[1].fd, .events = POLLIN } };

		if (rmd_now_ns() > end) {
			kill(pid, SIGKILL);
			waitpid(pid, NULL, 0);
			for (unsigned i = 0; i < 2; i++)
				if (s[i].fd >= 0)
					close(s[i].fd);
			fail_msg("%s %s hung: no exit within %d ms; output so far:\n%s%s", path,
				 argv[1] ? argv[1] : "", limit_ms, s[0].buf ? s[0].buf : "",
				 s[1].buf ? s[1].buf : "");
		}
		if (s[0].fd < 0 && s[1].fd < 0) {
			if (service)
				service(5);
			else
				poll(NULL, 0, 5);
			continue;
		}
		if (poll(p, 2, 5) > 0)
			for (unsigned i = 0; i < 2; i++)
				if (p[i].revents)
					sink_take(&s[i]);
		if (service)
			service(0);
	}
	r->took_ns = rmd_now_ns() - t0;
	r->status = status_of(ws);
	for (unsigned i = 0; i < 2; i++)
		if (!s[i].buf) {
			s[i].buf = calloc(1, 1);
			assert_non_null(s[i].buf);
		}
	r->out = s[0].buf;
	r->err = s[1].buf;
}

void run_free(struct run *r)
{
	free(r->out);
	free(r->err);
	r->out = r->err = NULL;
}

void assert_has(const char *hay, const char *needle, const char *what)
{
	if (!strstr(hay, needle))
		fail_msg("%s: \"%s\" missing from:\n%s", what, needle, hay);
}

void assert_has_each(const char *hay, const char *const *needles, const char *what)
{
	for (; *needles; needles++)
		assert_has(hay, *needles, what);
}

void assert_lacks(const char *hay, const char *needle, const char *what)
{
	if (strstr(hay, needle))
		fail_msg("%s: \"%s\" unexpected in:\n%s", what, needle, hay);
}

void assert_status(const struct run *r, int status, const char *what)
{
	if (r->status != status)
		fail_msg("%s: exit %d, expected %d\nstdout:\n%s\nstderr:\n%s", what, r->status,
			 status, r->out, r->err);
}

/* stream holds every string of has[] ({ "" }: is empty), and not lacks. */
static void check_stream(const char *stream, const char *const has[4], const char *lacks,
			 const char *what)
{
	if (has[0] && !*has[0] && *stream)
		fail_msg("%s: expected no output, got:\n%s", what, stream);
	for (unsigned i = 0; i < 4 && has[i]; i++)
		assert_has(stream, has[i], what);
	if (lacks)
		assert_lacks(stream, lacks, what);
}

void run_cases(const char *path, const struct run_case *c, size_t n, const struct run_opts *o)
{
	for (size_t k = 0; k < n; k++) {
		char what[256];
		struct run r;
		int w = snprintf(what, sizeof(what), "case %zu:", k);

		for (const char *const *a = c[k].args; *a && w > 0 && (size_t)w < sizeof(what); a++)
			w += snprintf(what + w, sizeof(what) - (size_t)w, " %s", *a);
		run_prog(&r, path, c[k].args, o);
		assert_status(&r, c[k].status, what);
		check_stream(r.out, c[k].out_has, c[k].out_lacks, what);
		check_stream(r.err, c[k].err_has, c[k].err_lacks, what);
		run_free(&r);
	}
}

size_t count_lines(const char *s)
{
	size_t n = 0;

	for (; *s; s++)
		n += *s == '\n';
	return n;
}

const char *line_with(const char *out, const char *needle, char *buf, size_t size)
{
	const char *hit = strstr(out, needle), *start, *end;

	if (!hit)
		fail_msg("no line holds \"%s\" in:\n%s", needle, out);
	for (start = hit; start > out && start[-1] != '\n'; start--)
		;
	end = strchr(hit, '\n');
	if (!end)
		end = hit + strlen(hit);
	assert_true((size_t)(end - start) < size);
	memcpy(buf, start, (size_t)(end - start));
	buf[end - start] = '\0';
	return buf;
}

/* ---- children beside the test --------------------------------------------------- */

static void kid_kill_at_exit(void)
{
	for (unsigned i = 0; i < KID_MAX; i++)
		if (kids[i].pid && !kids[i].reaped)
			kill(kids[i].pid, SIGKILL);
}

struct kid *kid_spawn(const char *name, const char *const *argv, const char *out_path, int fifo)
{
	static bool at_exit;
	struct kid *k;
	int pfd[2], ofd = -1;
	unsigned slot = 0;

	if (!at_exit)
		at_exit = atexit(kid_kill_at_exit) == 0;
	while (slot < KID_MAX - 1 && kids[slot].pid)
		slot++;
	if (kids[slot].pid)
		fail_msg("no free child slot for %s", name);
	k = &kids[slot];
	memset(k, 0, sizeof(*k));
	snprintf(k->name, sizeof(k->name), "%s", name);
	k->out = calloc(1, KID_OUT_MAX);
	assert_non_null(k->out);
	assert_int_equal(pipe2(pfd, O_CLOEXEC), 0);
	if (out_path) {
		ofd = open(out_path, O_WRONLY | O_CREAT | O_TRUNC | O_CLOEXEC, 0644);
		if (ofd < 0)
			fail_msg("%s: %s", out_path, strerror(errno));
	}
	k->pid = fork();
	assert_true(k->pid >= 0);
	if (k->pid == 0) {
		child_prepare(-1, ofd >= 0 ? ofd : pfd[1], pfd[1]);
		if (fifo > 0) {
			struct sched_param sp = { .sched_priority = fifo };

			if (sched_setscheduler(0, SCHED_FIFO, &sp) < 0)
				fprintf(stderr,
					"test: SCHED_FIFO %d: %s; running at normal priority\n",
					fifo, strerror(errno));
		}
		execvp(argv[0], (char *const *)argv);
		fprintf(stderr, "exec %s: %s\n", argv[0], strerror(errno));
		_exit(127);
	}
	close(pfd[1]);
	if (ofd >= 0)
		close(ofd);
	k->fd = pfd[0];
	fcntl(k->fd, F_SETFL, O_NONBLOCK);
	return k;
}

void kid_read(struct kid *k)
{
	for (;;) {
		ssize_t r;

		if (k->len >= KID_OUT_MAX - 4096) {
			size_t drop = k->len / 2;

			memmove(k->out, k->out + drop, k->len - drop);
			k->len -= drop;
		}
		r = read(k->fd, k->out + k->len, KID_OUT_MAX - 1 - k->len);
		if (r > 0) {
			k->len += (size_t)r;
			k->out[k->len] = '\0';
			continue;
		}
		if (r == 0 || (errno != EAGAIN && errno != EINTR)) {
			close(k->fd);
			k->fd = -1;
		}
		return;
	}
}

bool kid_poll_exit(struct kid *k)
{
	int ws;

	if (k->reaped)
		return true;
	if (waitpid(k->pid, &ws, WNOHANG) != k->pid)
		return false;
	k->reaped = true;
	k->status = status_of(ws);
	return true;
}

void kid_free(struct kid *k)
{
	if (!k || !k->pid)
		return;
	if (!k->reaped) {
		kill(k->pid, SIGKILL);
		waitpid(k->pid, NULL, 0);
	}
	if (k->fd >= 0)
		close(k->fd);
	free(k->out);
	memset(k, 0, sizeof(*k));
	k->fd = -1;
}

void kid_kill_all(void)
{
	for (unsigned i = 0; i < KID_MAX; i++)
		kid_free(&kids[i]);
}

unsigned kid_pollfds(struct pollfd *p, struct kid **who, unsigned max)
{
	unsigned n = 0;

	for (unsigned i = 0; i < KID_MAX && n < max; i++)
		if (kids[i].pid && kids[i].fd >= 0) {
			p[n] = (struct pollfd){ .fd = kids[i].fd, .events = POLLIN };
			who[n++] = &kids[i];
		}
	return n;
}

const char *kid_tail(const struct kid *k)
{
	size_t n = 3000;

	if (!k || !k->out)
		return "(no output)";
	return k->len > n ? k->out + k->len - n : k->out;
}

/* Without a service of the suite's: wait up to ms for k's output, and read it. */
static void kid_service(struct kid *k, service_fn *service, int ms)
{
	struct pollfd p = { .fd = k->fd, .events = POLLIN };

	if (service) {
		service(ms);
		return;
	}
	if (k->fd >= 0 && poll(&p, 1, ms) > 0)
		kid_read(k);
	else if (k->fd < 0)
		poll(NULL, 0, ms);
}

void kid_wait_output_held(struct kid *k, const char *needle, int ms, service_fn *service,
			  struct sleeper *ref)
{
	struct held_deadline d;

	held_deadline_start(&d, ref, ms);
	while (!strstr(k->out, needle)) {
		if (held_deadline_passed(&d) || k->fd < 0) {
			char held[96] = "";

			if (ref)
				snprintf(held, sizeof(held),
					 " (+ %.1f ms the machine held a reference thread off)",
					 (double)held_deadline_held_ns(&d) / 1e6);
			fail_msg("%s: no \"%s\" within %d ms%s%s; its output:\n%s", k->name, needle,
				 ms, held, k->fd < 0 ? " (it exited)" : "", kid_tail(k));
		}
		kid_service(k, service, 20);
	}
}

void kid_wait_output(struct kid *k, const char *needle, int ms, service_fn *service)
{
	kid_wait_output_held(k, needle, ms, service, NULL);
}

int kid_wait_exit_held(struct kid *k, int ms, service_fn *service, struct sleeper *ref)
{
	struct held_deadline d;

	held_deadline_start(&d, ref, ms);
	while (!kid_poll_exit(k) || k->fd >= 0) {
		if (held_deadline_passed(&d))
			fail_msg("%s (pid %d) did not exit within %d ms (%.1f ms more, what the "
				 "machine held a reference thread off meanwhile); its output:\n%s",
				 k->name, (int)k->pid, ms, (double)held_deadline_held_ns(&d) / 1e6,
				 kid_tail(k));
		kid_service(k, service, 10);
	}
	return k->status;
}

int kid_wait_exit(struct kid *k, int ms, service_fn *service)
{
	return kid_wait_exit_held(k, ms, service, NULL);
}

/* Thread tid of pid's state letter (stat(5): "TID (comm) S ..."), or 0 when unreadable. */
static char thread_state(pid_t pid, const char *tid)
{
	char path[64 + 256], line[512];
	const char *rp = NULL;
	FILE *f;

	snprintf(path, sizeof(path), "/proc/%d/task/%s/stat", (int)pid, tid);
	f = fopen(path, "re");
	if (f) {
		rp = fgets(line, sizeof(line), f) ? strrchr(line, ')') : NULL;
		fclose(f);
	}
	return rp && rp[1] == ' ' ? rp[2] : 0;
}

/* Every thread of pid is stopped (T) or traced (t); false when one is not, or none is seen. */
static bool pid_stopped(pid_t pid)
{
	char path[64];
	unsigned seen = 0, stopped = 0;
	struct dirent *e;
	DIR *d;

	snprintf(path, sizeof(path), "/proc/%d/task", (int)pid);
	d = opendir(path);
	if (!d)
		return false;
	while ((e = readdir(d)))
		if (e->d_name[0] != '.') {
			char st = thread_state(pid, e->d_name);

			seen++;
			stopped += st == 'T' || st == 't';
		}
	closedir(d);
	return seen && stopped == seen;
}

bool pid_wait_stopped(pid_t pid, int ms)
{
	int64_t end = rmd_now_ns() + ms * NS_PER_MS;

	while (!pid_stopped(pid)) {
		if (rmd_now_ns() > end)
			return false;
		poll(NULL, 0, 1);
	}
	return true;
}

/* ---- what the build wrote beside the programs --------------------------------- */

static const char *build_dir(void)
{
	const char *b = getenv("BUILD");

	return b && *b ? b : "build";
}

const char *built_version(char *buf, size_t size)
{
	char path[512], line[256];
	const char *q;
	FILE *f;

	snprintf(path, sizeof(path), "%s/gen/rmd_version.h", build_dir());
	f = fopen(path, "r");
	if (!f)
		fail_msg("%s: %s (the build writes it)", path, strerror(errno));
	buf[0] = '\0';
	while (fgets(line, sizeof(line), f))
		if (!strncmp(line, "#define RMD_VERSION \"", 21) && (q = strchr(line + 21, '"')))
			snprintf(buf, size, "%.*s", (int)(q - line - 21), line + 21);
	fclose(f);
	if (!buf[0])
		fail_msg("%s holds no RMD_VERSION", path);
	return buf;
}

void run_completion(struct run *r, const char *prog, const char *line, const char *net)
{
	static const char script[] = "source \"$1\" || exit 1\n"
				     "read -r -a COMP_WORDS <<<\"$2\"\n"
				     "[[ $2 == *' ' ]] && COMP_WORDS+=('')\n"
				     "COMP_CWORD=$((${#COMP_WORDS[@]} - 1))\n"
				     "[[ -n $3 ]] && export RMD_COMPLETION_NET=$3\n"
				     "\"$4\"\n"
				     "printf '%s\\n' \"${COMPREPLY[@]}\"\n";
	char path[512], fn[64];

	snprintf(path, sizeof(path), "%s/completion/%s", build_dir(), prog);
	snprintf(fn, sizeof(fn), "_%s", prog);
	for (char *c = fn; *c; c++)
		if (*c == '-')
			*c = '_';
	run_prog(r, "/bin/bash",
		 (const char *const[]){ "-c", script, "completion", path, line, net ? net : "", fn,
					NULL },
		 NULL);
	assert_status(r, 0, line);
}

void assert_completion(const char *prog, const char *line, const char *net, const char *want)
{
	struct run r;

	run_completion(&r, prog, line, net);
	if (strcmp(r.out, want))
		fail_msg("completion of \"%s\": offered\n%s\nexpected\n%s", line, r.out, want);
	run_free(&r);
}

void fake_net_dir(char *dir, size_t size)
{
	static const char *const ifs[][2] = { { "can0", "280" },
					      { "vcan1", "280" },
					      { "eth0", "1" } };
	char path[600];
	FILE *f;

	snprintf(dir, size, "/tmp/rmd-net-XXXXXX");
	assert_non_null(mkdtemp(dir));
	for (size_t i = 0; i < 3; i++) {
		snprintf(path, sizeof(path), "%s/%s", dir, ifs[i][0]);
		assert_int_equal(mkdir(path, 0755), 0);
		snprintf(path, sizeof(path), "%s/%s/type", dir, ifs[i][0]);
		f = fopen(path, "w");
		assert_non_null(f);
		fprintf(f, "%s\n", ifs[i][1]);
		fclose(f);
	}
}

bool find_rmd_plot(char *out, size_t len)
{
	const char *env = getenv("RMD_PLOT"), *build = getenv("BUILD");

	if (env && *env)
		snprintf(out, len, "%s", env);
	else
		snprintf(out, len, "%s/venv/bin/rmd-plot", build && *build ? build : "build");
	if (access(out, X_OK) != 0)
		snprintf(out, len, "build/venv/bin/rmd-plot");
	return access(out, X_OK) == 0;
}
