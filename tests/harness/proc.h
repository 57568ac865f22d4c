/* SPDX-License-Identifier: MIT */
/*
 * Programs as processes, for the system suites: find the built binaries,
 * run one to its end and keep what it wrote (run_prog()), or start
 * children that run beside the test (kid_*()): read their output as it
 * comes, wait for a line with a deadline, reap them, and kill every one at
 * the end of a test, at exit, or when the test dies (PR_SET_PDEATHSIG).
 * Every wait polls until a deadline; none sleeps for a result.
 */
#ifndef RMD_TESTS_PROC_H
#define RMD_TESTS_PROC_H

#include <stdbool.h>
#include <stddef.h>
#include <stdint.h>
#include <poll.h>
#include <sys/types.h>

/* ---- the programs under test ----------------------------------------------- */

/*
 * out = $env, else $BUILD/name, else build/name.  0 when it is executable;
 * else -1, after one line on stderr saying which variable to set.
 */
int find_prog(char *out, size_t size, const char *env, const char *name);

/* A new file from the mkstemp() template path (its name replaces the XXXXXX), holding text. */
void temp_file(char *path, const char *text);

/*
 * The entries of dir whose name begins with one of the characters of
 * `first` (e.g. "0123456789" for rmdd's incident recordings), sorted by
 * name, into names (at most max); their count (0 when dir is missing).
 */
#define DIR_NAME_MAX 256
unsigned dir_sorted(const char *dir, const char *first, char names[][DIR_NAME_MAX], unsigned max);

/*
 * Path's whole text (at most size - 1 bytes), NUL-terminated into buf; ""
 * when it cannot be read.  buf.
 */
const char *file_text(const char *path, char *buf, size_t size);

/* rm -rf dir (a suite's temporary folder): 0, or -1 when that failed. */
int rm_tree(const char *dir);

/* Close *fd if it is open (>= 0); *fd becomes -1. */
void close_fd(int *fd);

/*
 * Start path with args (argv[1..], NULL-terminated) as a child that dies
 * with the test: stdin /dev/null, stdout and stderr into one pipe whose
 * read end goes to *fd (blocking).  in_child(ctx), when given, runs in the
 * child just before exec (environment, limits).  The child's pid.
 */
pid_t spawn_piped(const char *path, const char *const *args, int *fd,
		  void (*in_child)(const void *ctx), const void *ctx);

/*
 * In a child before exec: JOURNAL_STREAM=DEV:INO of its stderr, as systemd
 * sets it when journald reads the stream, so the program logs as under
 * journald ("<N>" priority prefixes).  The ctx is unused: an in_child hook.
 */
void journal_stream_env(const void *ctx);

/*
 * spawn_piped() on a new pseudo-terminal: stdin, stdout and stderr are its
 * terminal (isatty() is true), *master its other side, which the test
 * reads (non-blocking) and writes.  The child's pid.
 */
pid_t spawn_pty(const char *path, const char *const *args, int *master,
		void (*in_child)(const void *ctx), const void *ctx);

/* ---- one run to its end ------------------------------------------------------ */

struct run {
	int status; /* exit status, or 128 + signal */
	int64_t took_ns;
	char *out; /* stdout, NUL-terminated (run_free()) */
	char *err; /* stderr */
};

/* Called while a run or a wait goes on, with how long it may block (ms). */
typedef void service_fn(int ms);

struct run_opts {
	const char *input; /* stdin: these bytes in a file, never a terminal; NULL: empty */
	size_t input_len;
	const char *unset_env; /* a variable the program must not inherit */
	int limit_ms;	       /* a run still going then is killed and fails the test; 0: 30 s */
	service_fn *service;   /* NULL: nothing else to do */
};

/* Run path with args (argv[1..], NULL-terminated) to its end; o may be NULL. */
void run_prog(struct run *r, const char *path, const char *const *args, const struct run_opts *o);

/* Free a run's output (a zeroed run is fine). */
void run_free(struct run *r);

/* needle in hay, else fail showing what: and hay. */
void assert_has(const char *hay, const char *needle, const char *what);
void assert_lacks(const char *hay, const char *needle, const char *what);
/* Each of the NULL-terminated needles in hay, as assert_has(). */
void assert_has_each(const char *hay, const char *const *needles, const char *what);
#define ASSERT_HAS_ALL(hay, what, ...) \
	assert_has_each(hay, (const char *const[]){ __VA_ARGS__, NULL }, what)

/* r exited with status, else fail showing both its streams. */
void assert_status(const struct run *r, int status, const char *what);

size_t count_lines(const char *s);

/*
 * The venv's rmd-plot into out: $RMD_PLOT, else $BUILD/venv/bin/rmd-plot,
 * else build/venv/bin/rmd-plot (one venv serves every BUILD).  True when
 * it is executable.
 */
bool find_rmd_plot(char *out, size_t len);

/* The line of out holding needle, copied into buf; fails when there is none. */
const char *line_with(const char *out, const char *needle, char *buf, size_t size);

/* One run and what it must show: a row of a table of command lines. */
struct run_case {
	const char *args[16]; /* argv[1..], NULL-terminated */
	int status;
	const char *out_has[4]; /* each in stdout; { "" }: stdout must be empty */
	const char *err_has[4]; /* likewise for stderr */
	const char *out_lacks;	/* NULL, or never in stdout */
	const char *err_lacks;
};

/* Run path once per case and check each; o as for run_prog(). */
void run_cases(const char *path, const struct run_case *c, size_t n, const struct run_opts *o);

/* ---- what the build wrote beside the programs --------------------------------- */

/*
 * The version the build gave the programs: RMD_VERSION of
 * $BUILD/gen/rmd_version.h (BUILD defaults to build), into buf; fails the
 * test when there is none.
 */
const char *built_version(char *buf, size_t size);

/*
 * Bash completion as a user gets it: source $BUILD/completion/prog, set
 * COMP_WORDS to the words of line (a trailing blank starts a new, empty
 * word) and call the script's function.  r->out holds the offered words,
 * one per line.  net, when given, replaces /sys/class/net (a folder of
 * NAME/type files: 280 is CAN).
 */
void run_completion(struct run *r, const char *prog, const char *line, const char *net);
/* run_completion() offers exactly want ("word\nword\n"; "\n" for nothing). */
void assert_completion(const char *prog, const char *line, const char *net, const char *want);

/*
 * A new folder (its path into dir) standing in for /sys/class/net: can0
 * and vcan1 (type 280, CAN) and eth0 (type 1).  rm_tree() it after.
 */
void fake_net_dir(char *dir, size_t size);

/* ---- children beside the test --------------------------------------------------- */

#define KID_MAX 8
#define KID_OUT_MAX (512 * 1024)

/* A child process whose stdout and stderr (or stderr only) the test reads. */
struct kid {
	char name[32];
	pid_t pid; /* 0: free slot */
	int fd;	   /* -1 at EOF */
	bool reaped;
	int status; /* exit status, or 128 + signal */
	size_t len;
	char *out; /* KID_OUT_MAX; the oldest half is dropped when full */
};

/*
 * Start argv[0] (a path, or a name looked up in PATH) as a child.  Its
 * stdout goes to out_path when given, else with stderr into the kid's
 * buffer.  fifo > 0: at SCHED_FIFO priority fifo (as root), else as is.
 */
struct kid *kid_spawn(const char *name, const char *const *argv, const char *out_path, int fifo);

/* Take what the child wrote so far (non-blocking). */
void kid_read(struct kid *k);

/* Reap k if it exited.  True when it has. */
bool kid_poll_exit(struct kid *k);

/* Kill (when still running), reap and forget k; NULL is fine. */
void kid_free(struct kid *k);

/* kid_free() every child: after each test, and at exit. */
void kid_kill_all(void);

/*
 * The output descriptors of the children still writing into p[] and the
 * kids into who[], at most max: for a suite's own poll() over them and
 * other descriptors.  Their count.
 */
unsigned kid_pollfds(struct pollfd *p, struct kid **who, unsigned max);

/* The last lines of a child's output, for failure messages. */
const char *kid_tail(const struct kid *k);

/*
 * Wait until k's output holds needle, at most ms; fails the test showing
 * its output.  service (NULL: read k) runs meanwhile and must read k.
 */
void kid_wait_output(struct kid *k, const char *needle, int ms, service_fn *service);

struct sleeper;

/*
 * kid_wait_output(), with ms counted in the time the machine let a thread
 * run (issue 10): the wait grows by what the reference sleeper ref (NULL:
 * none) was held off meanwhile.
 */
void kid_wait_output_held(struct kid *k, const char *needle, int ms, service_fn *service,
			  struct sleeper *ref);

/*
 * Wait until every thread of process pid is stopped (state T in
 * /proc/PID/task/TID/stat), at most ms; false when not.  A SIGSTOP takes
 * effect only once the process's threads run, which a busy machine can
 * delay: a SIGCONT sent before that cancels the stop (signal(7)).
 */
bool pid_wait_stopped(pid_t pid, int ms);

/* Wait for k to exit, at most ms (else fail); its status. */
int kid_wait_exit(struct kid *k, int ms, service_fn *service);

/*
 * kid_wait_exit(), with ms counted in the time the machine let a thread
 * run (issue 10): the wait grows by what the reference sleeper ref (NULL:
 * none) was held off meanwhile, so that a busy machine stretches it and an
 * idle one keeps it.
 */
int kid_wait_exit_held(struct kid *k, int ms, service_fn *service, struct sleeper *ref);

#endif /* RMD_TESTS_PROC_H */
