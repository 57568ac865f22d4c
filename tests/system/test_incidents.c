// SPDX-License-Identifier: MIT
/*
 * rmdd's incident recorder end to end (docs/design.md "Incidents"): the
 * built daemon ($RMDD, else $BUILD/rmdd) runs on simulated buses with
 * injected faults, as a real process with real signals, and each test
 * reads the recordings it wrote:
 *   - a motor lost, a motor faulted (error flags) and a bus leaving
 *     error-active each make a recording whose frames `rmdctl decode`
 *     ($RMDCTL, else $BUILD/rmdctl) reads line for line, whose states
 *     cover the window, and whose summary lists the events in the order
 *     they happened, the trigger at +0;
 *   - a stalled process (SIGSTOP for 80 ms, then SIGCONT) is an overrun
 *     burst; with no incidents.dir the recording goes to
 *     $STATE_DIRECTORY/incidents, as under systemd's StateDirectory=;
 *   - incidents.keep bounds the recordings: the oldest are removed, other
 *     files in the folder are not;
 *   - a motor lost amid overruns (SIGSTOP every 200 ms) names the
 *     recording that takes it in: "-lost", not "-overrun";
 *   - overruns alone make one recording a minute: a second stall soon after
 *     is logged as not recorded, a motor lost meanwhile is recorded;
 *   - each recording's window.lcmlog (issue 22.9), read with LCM's own
 *     eventlog reader: config_t first, naming the motors, then one state_t
 *     per recorded cycle (as many as states.csv's cycles, in order, every
 *     motor in each), and nothing on the live COMMAND channel; rmd-plot
 *     --log of the folder (the venv's) draws each motor's position.
 * The watchdog, safe actions and an intruding controller need an LCM
 * controller: tests/system/test_lcm_system.c.  Every wait has a deadline;
 * RMD_TEST_FILTER=name runs one test.
 */
#define _GNU_SOURCE
#include <errno.h>
#include <limits.h>
#include <pthread.h>
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

#include <sys/stat.h>

#include <cmocka.h>

#include <lcm/eventlog.h>

#include "harness/proc.h"
#include "rmd/config.h"
#include "rmd/rmd_config_t.h"
#include "rmd/rmd_state_t.h"
#include "rmd/time.h"

#define START_MS 10000
#define INCIDENT_MS 20000
#define SELF_FIFO_PRIO 60 /* the test thread while it times a stall (above rmdd's loop) */
#define NS_PER_MS INT64_C(1000000)

static char rmdd[4096], rmdctl[4096];
static char tmpdir[256];
static unsigned test_no;

/* The sim bus and motors of every test, after the test's own keys. */
static const char motors_yaml[] =
	"loop: {rate_hz: 1000}\n"
	"safety: {missed_replies_lost: 10, lost_motor_action: motor}\n"
	"probe: {on_missing: start}\n"
	"lcm: {url: \"memq://\"}\n"
	"motors:\n"
	"  - {name: a, bus: sim0, id: 1, mode: torque, torque_constant_nm_a: 2.0}\n"
	"  - {name: b, bus: sim0, id: 2, mode: speed, torque_constant_nm_a: 2.0}\n"
	"  - {name: c, bus: sim0, id: 3, mode: position, torque_constant_nm_a: 2.0}\n";

/* A folder of this test under the suite's. */
static void test_dir(char *out, size_t len, const char *name)
{
	snprintf(out, len, "%s/%u-%s", tmpdir, ++test_no, name);
	assert_int_equal(mkdir(out, 0700), 0);
}

/* incidents: (dir inc, then `more`) and sim0 with seed and the fault list `faults`. */
static void fault_keys(char *out, size_t len, const char *inc, const char *more, unsigned seed,
		       const char *faults)
{
	snprintf(out, len,
		 "incidents: {dir: \"%s\", %s}\n"
		 "buses:\n"
		 "  - name: sim0\n"
		 "    type: sim\n"
		 "    sim:\n"
		 "      seed: %u\n"
		 "      faults:\n%s",
		 inc, more, seed, faults);
}

/* Start rmdd on `motors` plus `keys` (incidents:, buses:), wait until it runs. */
static struct kid *start_on(const char *dir, const char *keys, const char *motors)
{
	char path[512], text[4096];
	struct kid *k;
	FILE *f;

	snprintf(path, sizeof(path), "%s/rmdd.yaml", dir);
	snprintf(text, sizeof(text), "%s%s", keys, motors);
	f = fopen(path, "w");
	assert_non_null(f);
	fputs(text, f);
	assert_int_equal(fclose(f), 0);
	k = kid_spawn("rmdd", (const char *const[]){ rmdd, "--config", path, NULL }, NULL, 0);
	assert_non_null(k);
	kid_wait_output(k, "rmdd: running:", START_MS, NULL);
	return k;
}

/* Start rmdd on motors_yaml plus `keys` (incidents:, buses:), wait until it runs. */
static struct kid *start(const char *dir, const char *keys)
{
	return start_on(dir, keys, motors_yaml);
}

static void stop(struct kid *k)
{
	kill(k->pid, SIGTERM);
	assert_int_equal(kid_wait_exit(k, 10000, NULL), 0);
}

/*
 * Run rmdd with fault_keys(inc, more, seed, faults) in dir until its log
 * has each of the NULL-terminated `logged` lines, then stop it (exit 0).
 */
static void run_faults(const char *dir, const char *inc, const char *more, unsigned seed,
		       const char *faults, const char *const *logged)
{
	char keys[1024];
	struct kid *k;

	fault_keys(keys, sizeof(keys), inc, more, seed, faults);
	k = start(dir, keys);
	for (; *logged; logged++)
		kid_wait_output(k, *logged, INCIDENT_MS, NULL);
	assert_has(k->out, "rmdd: incident recorded in ", "rmdd's log");
	stop(k);
}

/*
 * A folder `name` of this test (into dir, its incidents/ into inc) and rmd
 * started there with fault_keys(inc, more, seed 7, faults).
 */
static struct kid *start_faults(const char *name, char *dir, size_t dlen, char *inc, size_t ilen,
				const char *more, const char *faults)
{
	char keys[1024];

	test_dir(dir, dlen, name);
	snprintf(inc, ilen, "%s/incidents", dir);
	fault_keys(keys, sizeof(keys), inc, more, 7, faults);
	return start(dir, keys);
}

/* The recordings under dir (names "YYYYMMDD-HHMMSS-mmm-kind"), sorted; their count. */
static unsigned recordings(const char *dir, char names[][DIR_NAME_MAX], unsigned max)
{
	return dir_sorted(dir, "0123456789", names, max);
}

/* The recording of `kind` under dir (its path into out); fails when there is none. */
/* Whether recording `name` is filed as `kind` (its name ends in "-kind"). */
static bool filed_as(const char *name, const char *kind)
{
	size_t n = strlen(name), k = strlen(kind);

	return n > k + 1 && name[n - k - 1] == '-' && !strcmp(name + n - k, kind);
}

static void recording_of(const char *dir, const char *kind, char *out, size_t len)
{
	char names[64][DIR_NAME_MAX];
	unsigned n = recordings(dir, names, 64);

	for (unsigned i = 0; i < n; i++) {
		if (filed_as(names[i], kind)) {
			snprintf(out, len, "%s/%.300s", dir, names[i]);
			return;
		}
	}
	fail_msg("no %s recording under %s (%u recordings)", kind, dir, n);
}

/* How many recordings under dir are filed as `kind`. */
static unsigned recordings_of(const char *dir, const char *kind)
{
	char names[64][DIR_NAME_MAX];
	unsigned n = recordings(dir, names, 64), m = 0;

	for (unsigned i = 0; i < n; i++)
		m += filed_as(names[i], kind);
	return m;
}

static char *slurp(const char *path)
{
	FILE *f = fopen(path, "r");
	char *buf;
	long n;

	if (!f)
		fail_msg("%s: %s", path, strerror(errno));
	fseek(f, 0, SEEK_END);
	n = ftell(f);
	fseek(f, 0, SEEK_SET);
	buf = calloc(1, (size_t)n + 1);
	assert_non_null(buf);
	assert_int_equal(fread(buf, 1, (size_t)n, f), (size_t)n);
	fclose(f);
	return buf;
}

/* One line of the summary's "What happened" list. */
struct ev {
	double t_s; /* from the trigger named in What: */
	bool trigger;
	char text[200];
};

/* The summary's event list, checked to be in time order; its length. */
static unsigned summary_events(const char *summary, struct ev *ev, unsigned max)
{
	const char *p = strstr(summary, "What happened, in order");
	unsigned n = 0;

	assert_non_null(p);
	p = strchr(p, '\n') + 1;
	while (*p == ' ' && n < max) {
		char mark;
		int used = 0;

		if (sscanf(p, " %lf %c %n", &ev[n].t_s, &mark, &used) < 2 || !used)
			break;
		ev[n].trigger = mark == '*';
		p += ev[n].trigger ? used : used - 2; /* not a trigger: the mark was the text */
		snprintf(ev[n].text, sizeof(ev[n].text), "%.*s", (int)strcspn(p, "\n"), p);
		if (n && ev[n].t_s < ev[n - 1].t_s)
			fail_msg("summary out of order at \"%s\":\n%s", ev[n].text, summary);
		n++;
		p += strcspn(p, "\n") + 1;
	}
	return n;
}

/* Index of the first event holding needle (a trigger when `trigger`), else fails. */
static unsigned event_at(const struct ev *ev, unsigned n, const char *needle, bool trigger,
			 const char *summary)
{
	for (unsigned i = 0; i < n; i++)
		if (strstr(ev[i].text, needle) && (!trigger || ev[i].trigger))
			return i;
	fail_msg("no %s \"%s\" in the summary:\n%s", trigger ? "trigger" : "event", needle,
		 summary);
	return 0;
}

static unsigned lines_of(const char *s)
{
	unsigned n = 0;

	for (; *s; s++)
		n += *s == '\n';
	return n;
}

/* All the periods the overruns listed in a summary skipped. */
static long periods_skipped(const struct ev *ev, unsigned n)
{
	long sum = 0, k;

	for (unsigned j = 0; j < n; j++)
		if (strstr(ev[j].text, "rt loop: overrun, ") &&
		    sscanf(strstr(ev[j].text, "overrun, "), "overrun, %ld", &k) == 1)
			sum += k;
	return sum;
}

/*
 * The recording at path: its frames decode with rmdctl decode line for
 * line, its states cover [-before, +after] of the trigger at 1 kHz for 3
 * motors, but for the periods the loop did not run: those its summary's
 * overruns skipped (a busy machine, or a stall the test made); its summary
 * returned (free it).
 */
static char *check_recording(const char *path, double before_s, double after_s)
{
	char frames[600], states_path[600], summary_path[600];
	struct run r;
	char *frames_text, *states, *summary;
	unsigned nframes, nstates;
	struct ev ev[64];
	double ran_s;

	snprintf(frames, sizeof(frames), "%s/frames-sim0.log", path);
	snprintf(states_path, sizeof(states_path), "%s/states.csv", path);
	snprintf(summary_path, sizeof(summary_path), "%s/summary.txt", path);
	summary = slurp(summary_path);
	ran_s = before_s + after_s - periods_skipped(ev, summary_events(summary, ev, 64)) / 1000.0;
	frames_text = slurp(frames);
	nframes = lines_of(frames_text);
	run_prog(&r, rmdctl, (const char *const[]){ "decode", "--protocol", "v3", frames, NULL },
		 NULL);
	assert_status(&r, 0, "rmdctl decode over the recorded frames");
	assert_int_equal(count_lines(r.out), nframes);
	assert_has(r.out, "read_status_2", "rmdctl decode");
	/* at least one frame a cycle over the window */
	if (nframes < (unsigned)(0.9 * ran_s * 1000))
		fail_msg("%u frames in %s: fewer than one a cycle over %.3f s; the summary:\n%s",
			 nframes, frames, ran_s, summary);
	run_free(&r);
	states = slurp(states_path);
	nstates = lines_of(states) - 1;
	/* every motor, every cycle of the window (the tail may be cut by a stop: 90 %) */
	if (nstates < (unsigned)(0.9 * 3 * ran_s * 1000))
		fail_msg("%u states in %s: fewer than 3 a cycle over %.3f s; the summary:\n%s",
			 nstates, states_path, ran_s, summary);
	assert_has(summary, "What:", summary_path);
	assert_has(summary, "rmdctl decode --protocol v3 frames-sim0.log", summary_path);
	print_message("%s: %u frames decoded, %u states\n", strrchr(path, '/') + 1, nframes,
		      nstates);
	free(frames_text);
	free(states);
	return summary;
}

/*
 * The recording of `kind` under inc, checked as check_recording() does
 * over a 0.5 s + 0.2 s window; its summary's events into ev (*n), and the
 * index of the trigger holding needle, which must be the first (at +0).
 * *summary: free it.
 */
static unsigned first_trigger(const char *inc, const char *kind, const char *needle, struct ev *ev,
			      unsigned *n, char **summary)
{
	char path[700];
	unsigned at;

	recording_of(inc, kind, path, sizeof(path));
	*summary = check_recording(path, 0.5, 0.2);
	*n = summary_events(*summary, ev, 64);
	at = event_at(ev, *n, needle, true, *summary);
	assert_true(ev[at].t_s == 0.0);
	return at;
}

/* Cycles (distinct values of the second column) of a recording's states.csv. */
static unsigned csv_cycles(const char *rec, unsigned *rows)
{
	char path[800], line[512];
	unsigned long long last = ~0ull, c;
	unsigned n = 0;
	FILE *f;

	snprintf(path, sizeof(path), "%s/states.csv", rec);
	f = fopen(path, "r");
	if (!f)
		fail_msg("%s: cannot open", path);
	*rows = 0;
	while (fgets(line, sizeof(line), f)) {
		const char *comma = strchr(line, ',');

		if (!comma || sscanf(comma + 1, "%llu", &c) != 1)
			continue; /* the header */
		++*rows;
		n += c != last;
		last = c;
	}
	fclose(f);
	return n;
}

/*
 * Issue 22.9: rec/window.lcmlog opens with LCM's own reader: config_t
 * first, naming the motors; one state_t per cycle of states.csv, cycles
 * rising, every motor in each; timestamps rising; nothing on RMD_COMMAND
 * (a replay must never drive a running rmdd's motors).
 */
static void check_lcmlog(const char *rec, unsigned n_motors, const char *first_name)
{
	char path[800];
	lcm_eventlog_t *log;
	lcm_eventlog_event_t *ev;
	unsigned states = 0, events = 0, rows, cycles = csv_cycles(rec, &rows);
	int64_t last_cycle = -1, last_ts = 0;
	unsigned motors_in_states = 0;

	snprintf(path, sizeof(path), "%s/window.lcmlog", rec);
	log = lcm_eventlog_create(path, "r");
	if (!log)
		fail_msg("%s: LCM's reader cannot open it", path);
	while ((ev = lcm_eventlog_read_next_event(log))) {
		if (events == 0) {
			rmd_config_t c;

			if (strcmp(ev->channel, "RMD_CONFIG") ||
			    rmd_config_t_decode(ev->data, 0, ev->datalen, &c) < 0)
				fail_msg("%s: first event on %s, not a config_t on RMD_CONFIG",
					 path, ev->channel);
			assert_int_equal(c.motor_count, n_motors);
			assert_string_equal(c.motor[0].name, first_name);
			rmd_config_t_decode_cleanup(&c);
		}
		if (!strcmp(ev->channel, "RMD_COMMAND"))
			fail_msg("%s: an event on the live RMD_COMMAND channel", path);
		if (ev->timestamp < last_ts)
			fail_msg("%s: event %u's timestamp goes back", path, events);
		last_ts = ev->timestamp;
		if (!strcmp(ev->channel, "RMD_STATE")) {
			rmd_state_t st;

			assert_true(rmd_state_t_decode(ev->data, 0, ev->datalen, &st) >= 0);
			if (st.cycle <= last_cycle)
				fail_msg("%s: state_t cycle %lld after %lld", path,
					 (long long)st.cycle, (long long)last_cycle);
			last_cycle = st.cycle;
			motors_in_states += (unsigned)st.count;
			assert_int_equal(st.motor[st.count - 1].index, st.count - 1);
			rmd_state_t_decode_cleanup(&st);
			states++;
		}
		events++;
		lcm_eventlog_free_event(ev);
	}
	lcm_eventlog_destroy(log);
	if (states == 0 || states != cycles || motors_in_states != rows)
		fail_msg("%s: %u state_t holding %u motor states; states.csv: %u cycles, %u rows",
			 path, states, motors_in_states, cycles, rows);
}

/*
 * Issue 22.9 and 22.5: rmd-plot --log opens an incident folder (its
 * window.lcmlog): each motor's position series named from the recorded
 * config_t, a row per recorded cycle, and a PNG.  False without rmd-plot.
 */
static bool check_plot(const char *rec, unsigned cycles)
{
	char plot[PATH_MAX], png[800];
	struct run r;
	unsigned char sig[8] = { 0 };
	FILE *f;

	if (!find_rmd_plot(plot, sizeof(plot)))
		return false;
	run_prog(&r, plot,
		 (const char *const[]){ "--log", rec, "--field", "position", "--csv", "-", NULL },
		 &(struct run_opts){ .limit_ms = 60000 });
	assert_status(&r, 0, "rmd-plot --log of an incident folder");
	for (const char *const *name = (const char *const[]){ "a", "b", "c", NULL }; *name;
	     name++) {
		char series[32];
		unsigned n = 0;

		snprintf(series, sizeof(series), ",%s.position,", *name);
		for (const char *p = r.out; (p = strstr(p, series)); p++)
			n++;
		if (n != cycles)
			fail_msg(
				"rmd-plot --log %s: %u rows of %s, want one per recorded cycle (%u)",
				rec, n, series, cycles);
	}
	run_free(&r);
	snprintf(png, sizeof(png), "%s/position.png", rec);
	run_prog(&r, plot,
		 (const char *const[]){ "--log", rec, "--field", "position", "--out", png, NULL },
		 &(struct run_opts){ .limit_ms = 60000 });
	assert_status(&r, 0, "rmd-plot --log --out of an incident folder");
	run_free(&r);
	f = fopen(png, "rb");
	assert_non_null(f);
	assert_int_equal(fread(sig, 1, sizeof(sig), f), sizeof(sig));
	fclose(f);
	assert_memory_equal(sig, "\x89PNG\r\n\x1a\n", 8);
	return true;
}

static void test_lost_fault_and_bus_off_recorded(void **state)
{
	char dir[512], inc[600];
	struct ev ev[64];
	char *summary;
	unsigned n, at;
	bool plot_missing = false;

	(void)state;
	test_dir(dir, sizeof(dir), "faults");
	snprintf(inc, sizeof(inc), "%s/incidents", dir);
	run_faults(
		dir, inc, "seconds_before: 0.5, seconds_after: 0.2, overrun_burst: 1000000", 7,
		"        - {kind: disappear, motor: 3, start_s: 1.5, end_s: 1.8, param: 1}\n"
		"        - {kind: error_flag, motor: 1, start_s: 3.0, end_s: 3.3, param: 0x1000}\n"
		"        - {kind: bus_off, start_s: 4.5, end_s: 4.55}\n",
		(const char *const[]){ "-lost: sim0: motor 3 (c): ready -> lost",
				       "-fault: sim0: motor 1 (a): ready -> fault",
				       "-bus: sim0: bus bus-off", NULL });

	/* lost: the motor's loss is the trigger */
	first_trigger(inc, "lost", "sim0: motor 3 (c): ready -> lost", ev, &n, &summary);
	assert_non_null(strstr(summary, "window.lcmlog  an LCM log: config_t, "));
	free(summary);
	{
		char rec[700];

		unsigned rows, cycles;

		recording_of(inc, "lost", rec, sizeof(rec));
		check_lcmlog(rec, 3, "a");
		cycles = csv_cycles(rec, &rows);
		if (!check_plot(rec, cycles))
			plot_missing = true;
	}

	/* fault: the flags, then the state change they cause, in the loop's order */
	at = first_trigger(inc, "fault", "sim0: motor 1 (a): ready -> fault", ev, &n, &summary);
	assert_true(event_at(ev, n, "sim0: motor 1 (a): error flags 0x1000", false, summary) < at);
	free(summary);

	/* bus-off: first, then the motors it cut off are lost, then error-active again */
	at = first_trigger(inc, "bus", "sim0: bus bus-off", ev, &n, &summary);
	assert_true(event_at(ev, n, "sim0: motor 1 (a): ready -> lost", true, summary) > at);
	assert_true(event_at(ev, n, "sim0: bus error-active", false, summary) > at);
	free(summary);
	if (plot_missing) {
		fprintf(stderr, "SKIP: rmd-plot --log of an incident folder not checked: no "
				"build/venv/bin/rmd-plot (make python-venv, or set RMD_PLOT)\n");
		skip();
	}
}

/*
 * Issue 32 point 14: a motor `protocol: auto` found speaking V4 is named
 * and decoded as V4, not as its entry's protocol: its error flags by V4's
 * names (0x0800, V4.3, is no V3 bit), its incident's decode hint
 * `--protocol v4`, its statistics line `v4`.
 */
static void test_found_dialect_named(void **state)
{
	static const char v4_motor[] =
		"loop: {rate_hz: 1000}\n"
		"lcm: {url: \"memq://\"}\n"
		"motors:\n"
		"  - {name: a, bus: sim0, id: 1, protocol: auto, mode: torque,"
		" torque_constant_nm_a: 2.0, sim: {firmware: v4}}\n";
	char dir[512], inc[600], keys[1024], rec[700], sum[800];
	struct kid *k;
	char *summary;

	(void)state;
	test_dir(dir, sizeof(dir), "dialect");
	snprintf(inc, sizeof(inc), "%s/incidents", dir);
	fault_keys(keys, sizeof(keys), inc, "seconds_before: 0.5, seconds_after: 0.2", 7,
		   "        - {kind: error_flag, motor: 1, start_s: 1.0, end_s: 1.3, "
		   "param: 0x0800}\n");
	k = start_on(dir, keys, v4_motor);
	kid_wait_output(k, "-fault: sim0: motor 1 (a): ready -> fault", INCIDENT_MS, NULL);
	assert_has(k->out, "protocol auto: v4", "rmdd's bring-up report");
	assert_has(k->out, "error flags 0x0800 (component_over_temperature)", "rmdd's log");
	stop(k);
	assert_has(k->out, "motor a (sim0 id 1, v4): ", "rmdd's statistics at exit");
	recording_of(inc, "fault", rec, sizeof(rec));
	snprintf(sum, sizeof(sum), "%s/summary.txt", rec);
	summary = slurp(sum);
	assert_has(summary, "rmdctl decode --protocol v4 frames-sim0.log", sum);
	free(summary);
}

/* The CLOCK_MONOTONIC time of a summary's When:, ns. */
static int64_t summary_when_ns(const char *summary)
{
	const char *p = strstr(summary, "(CLOCK_MONOTONIC ");
	double s;

	if (!p || sscanf(p, "(CLOCK_MONOTONIC %lf", &s) != 1)
		fail_msg("no CLOCK_MONOTONIC time in the summary's When:\n%s", summary);
	return (int64_t)(s * 1e9);
}

/*
 * Of the recordings rmdd's log (out) says it wrote, the one whose triggers
 * hold the first overrun at or after t_ns (CLOCK_MONOTONIC): its path, and
 * that overrun's periods skipped.  False while there is none.
 */
static bool overrun_from(const char *out, int64_t t_ns, char *path, size_t len, long *skipped)
{
	static const char said[] = "rmdd: incident recorded in ";
	int64_t best = INT64_MAX;

	for (const char *p = out; (p = strstr(p, said)); p++) {
		char dir[700], sum_path[800], *summary;
		static struct ev ev[512]; /* a slow build's recording lists many overruns */
		int64_t when;
		unsigned n;

		p += strlen(said);
		snprintf(dir, sizeof(dir), "%.*s", (int)strcspn(p, ": \n"), p);
		snprintf(sum_path, sizeof(sum_path), "%s/summary.txt", dir);
		summary = slurp(sum_path);
		when = summary_when_ns(summary);
		n = summary_events(summary, ev, 512);
		for (unsigned j = 0; j < n; j++) {
			int64_t t = when + (int64_t)(ev[j].t_s * 1e9);

			if (!ev[j].trigger || !strstr(ev[j].text, "rt loop: overrun, ") ||
			    t < t_ns || t >= best)
				continue;
			best = t;
			snprintf(path, len, "%s", dir);
			assert_int_equal(sscanf(strstr(ev[j].text, "overrun, "), "overrun, %ld",
						skipped),
					 1);
		}
		free(summary);
	}
	return best != INT64_MAX;
}

/*
 * Raise the calling thread to SCHED_FIFO prio (as root) or back to normal
 * (prio 0), so that the stall it times is as long as asked on a busy
 * machine.  Where it is not granted the stall is measured all the same.
 */
static void self_fifo(int prio)
{
	struct sched_param sp = { .sched_priority = prio };

	pthread_setschedparam(pthread_self(), prio ? SCHED_FIFO : SCHED_OTHER, &sp);
}

static void test_overrun_burst_goes_to_the_state_directory(void **state)
{
	char dir[512], keys[512], path[700], state_dir[600], inc[700], names[8][DIR_NAME_MAX];
	char sum_path[800];
	/* shorter than the motors' comm-loss time (RMD_CONFIG_DEFAULT_COMM_LOSS_MS): they keep answering */
	struct timespec stall = { .tv_sec = 0, .tv_nsec = 80 * 1000000 };
	struct ev ev[64];
	struct kid *k;
	char *summary, *states, *p;
	double last = 0, gap = 0;
	long skipped = 0;
	unsigned n, at;

	(void)state;
	/*
	 * The stall's overrun is the first at or after the SIGCONT: a slow
	 * build on a busy machine may overrun by itself before it, and that
	 * recording is another.  The stall must stay shorter than the
	 * motors' comm-loss time, or they trip and rightly lead the recording
	 * as lost motors: measured, and on a machine that held this test off
	 * that long the stall runs again, said on a "busy machine:" line.
	 */
	for (unsigned tries = 1;; tries++) {
		int64_t t_a, t_b, t_c, t_d, end;
		const char *name;

		test_dir(dir, sizeof(dir), "overrun");
		snprintf(state_dir, sizeof(state_dir), "%s/state", dir);
		snprintf(inc, sizeof(inc), "%s/incidents", state_dir);
		snprintf(keys, sizeof(keys),
			 "incidents: {seconds_before: 0.5, seconds_after: 0.2, overrun_burst: 75}\n"
			 "buses: [{name: sim0, type: sim, sim: {seed: 3}}]\n");
		/* systemd's StateDirectory=rmdd sets it; no incidents.dir: recordings go under it */
		setenv("STATE_DIRECTORY", state_dir, 1);
		k = start(dir, keys);
		unsetenv("STATE_DIRECTORY");
		/* a window's worth of cycles first (the stall is not a result to wait for) */
		nanosleep(&(struct timespec){ .tv_sec = 1 }, NULL);
		/*
		 * the whole process stops: the loop wakes 80 periods late, or
		 * later.  The stall is timed from when the kernel says every
		 * thread stopped: a busy machine can delay that, and a SIGCONT
		 * before it would cancel the stop.
		 */
		self_fifo(SELF_FIFO_PRIO);
		t_a = rmd_now_ns();
		assert_int_equal(kill(k->pid, SIGSTOP), 0);
		if (!pid_wait_stopped(k->pid, START_MS))
			fail_msg("rmdd not stopped %d ms after SIGSTOP", START_MS);
		t_b = rmd_now_ns();
		nanosleep(&stall, NULL);
		t_c = rmd_now_ns();
		assert_int_equal(kill(k->pid, SIGCONT), 0);
		t_d = rmd_now_ns();
		self_fifo(0);
		/* its overrun is dated at the loop's first wake-up after the SIGCONT */
		end = rmd_now_ns() + INCIDENT_MS * NS_PER_MS;
		while (!overrun_from(k->out, t_c, path, sizeof(path), &skipped)) {
			if (rmd_now_ns() > end)
				fail_msg("no recording of the stall's overrun in %d ms:\n%s",
					 INCIDENT_MS, kid_tail(k));
			nanosleep(&(struct timespec){ .tv_nsec = 20 * 1000000 }, NULL);
			kid_read(k);
		}
		stop(k);
		name = strrchr(path, '/') + 1;
		print_message("stall: the process stopped for %.1f .. %.1f ms; its overrun in %s\n",
			      (double)(t_c - t_b) / 1e6, (double)(t_d - t_a) / 1e6, name);
		if (strstr(name, "-overrun"))
			break;
		if (t_d - t_a < RMD_CONFIG_DEFAULT_COMM_LOSS_MS * NS_PER_MS || tries == 3)
			fail_msg("the stall's overrun went into %s, not an -overrun recording, "
				 "though the process stopped for less than the motors' comm-loss "
				 "time (%.1f ms of %d ms):\n%s",
				 name, (double)(t_d - t_a) / 1e6, RMD_CONFIG_DEFAULT_COMM_LOSS_MS,
				 k->out);
		print_message("busy machine: the process stayed stopped up to %.1f ms, past the "
			      "motors' comm-loss time (%d ms): the machine held this test off "
			      "before its SIGCONT, and the motors' trip rightly named the "
			      "recording (%s); again\n",
			      (double)(t_d - t_a) / 1e6, RMD_CONFIG_DEFAULT_COMM_LOSS_MS, name);
	}

	assert_true(recordings(inc, names, 8) >= 1);
	snprintf(sum_path, sizeof(sum_path), "%s/summary.txt", path);
	summary = slurp(sum_path);
	n = summary_events(summary, ev, 64);
	at = event_at(ev, n, "rt loop: overrun, ", true, summary);
	assert_true(ev[at].t_s == 0.0);
	assert_true(skipped >= 75);
	free(summary);
	/* the periods the overruns of the window skipped have no cycle */
	summary = check_recording(path, 0.5, 0.2);
	/* the states show the stall as one gap at least as long as the stop */
	snprintf(path + strlen(path), sizeof(path) - strlen(path), "/states.csv");
	states = slurp(path);
	for (p = strchr(states, '\n') + 1; *p; p = strchr(p, '\n') + 1) {
		double t = strtod(p, NULL);

		if (last > 0 && t - last > gap)
			gap = t - last;
		last = t;
	}
	print_message("stall: %ld periods skipped, %.0f ms between two recorded cycles\n", skipped,
		      gap * 1000);
	/*
	 * The process was stopped for the whole stall: no cycle can have been
	 * recorded in it.  (The periods skipped count from the tick, and the
	 * cycle before the stop may itself have run late on a busy machine,
	 * so they can exceed the gap between the recorded cycles' times.)
	 */
	assert_true(gap >= (double)stall.tv_nsec / 1e9);
	free(states);
	free(summary);
}

/* Stop the whole process for `ms`: the loop wakes that many periods late, or later. */
static void stall(struct kid *k, long ms)
{
	struct timespec ts = { .tv_sec = 0, .tv_nsec = ms * 1000000 };

	assert_int_equal(kill(k->pid, SIGSTOP), 0);
	nanosleep(&ts, NULL);
	assert_int_equal(kill(k->pid, SIGCONT), 0);
}

/*
 * Overruns alone make one recording a RMDD_INCIDENT_OVERRUN_HOLDOFF_S (60 s):
 * a second burst soon after the first is said in the log, not recorded,
 * and a motor lost meanwhile is recorded all the same.
 */
static void test_overruns_recorded_once_a_minute(void **state)
{
	char dir[512], inc[600];
	struct kid *k;

	(void)state;
	/* the motor disappears after both stalls (each waits for its outcome first) */
	k = start_faults(
		"holdoff", dir, sizeof(dir), inc, sizeof(inc),
		"seconds_before: 0.3, seconds_after: 0.1, overrun_burst: 75",
		"        - {kind: disappear, motor: 3, start_s: 6, end_s: 300, param: 1}\n");
	stall(k, 80);
	kid_wait_output(k, "-overrun: rt loop: overrun, ", INCIDENT_MS, NULL);
	stall(k, 80);
	kid_wait_output(k, "rmdd: incident not recorded: rt loop: overrun, ", INCIDENT_MS, NULL);
	kid_wait_output(k, "-lost: sim0: motor 3 (c): ready -> lost", INCIDENT_MS, NULL);
	stop(k);
	assert_int_equal(recordings_of(inc, "overrun"), 1);
	assert_int_equal(recordings_of(inc, "lost"), 1);
}

static void test_keep_bounds_the_recordings(void **state)
{
	char dir[512], inc[600], other[700], old[700], names[16][DIR_NAME_MAX];
	unsigned n;

	(void)state;
	test_dir(dir, sizeof(dir), "keep");
	snprintf(inc, sizeof(inc), "%s/incidents", dir);
	assert_int_equal(mkdir(inc, 0700), 0);
	/* somebody's notes and an old recording */
	snprintf(other, sizeof(other), "%s/notes", inc);
	snprintf(old, sizeof(old), "%s/20000101-000000-000-lost", inc);
	assert_int_equal(mkdir(other, 0700), 0);
	assert_int_equal(mkdir(old, 0700), 0);
	run_faults(dir, inc,
		   "seconds_before: 0.3, seconds_after: 0.1, keep: 2, overrun_burst: 1000000", 5,
		   "        - {kind: disappear, motor: 1, start_s: 1.5, end_s: 1.7, param: 1}\n"
		   "        - {kind: disappear, motor: 2, start_s: 2.5, end_s: 2.7, param: 1}\n"
		   "        - {kind: disappear, motor: 3, start_s: 3.5, end_s: 3.7, param: 1}\n",
		   (const char *const[]){ "-lost: sim0: motor 1 (a): ready -> lost",
					  "-lost: sim0: motor 2 (b): ready -> lost",
					  "-lost: sim0: motor 3 (c): ready -> lost", NULL });

	n = recordings(inc, names, 16);
	assert_int_equal(n, 2);
	/* the newest two: motors 2 and 3; the old one and motor 1's removed, the notes kept */
	for (unsigned i = 0; i < n; i++) {
		char p[1024], *summary;

		snprintf(p, sizeof(p), "%s/%.300s/summary.txt", inc, names[i]);
		summary = slurp(p);
		assert_has(summary, i ? "What:    sim0: motor 3 (c)" : "What:    sim0: motor 2 (b)",
			   p);
		free(summary);
	}
	assert_int_equal(access(old, F_OK), -1);
	assert_int_equal(access(other, F_OK), 0);
}

/*
 * rmdd's log (out) says motor 3 was lost and, after that, that a recording
 * was written (it holds the loss, or the next one will: stop() writes it).
 */
static bool lost_recorded(const char *out)
{
	const char *at = strstr(out, "sim0: motor 3 (c): lost");

	return at && strstr(at, "rmdd: incident recorded in ");
}

/*
 * A motor lost while the machine keeps overrunning: the overruns' recording
 * takes the loss in (it comes within their tail), and is named after the
 * loss, not filed as one more overrun.  Overruns alone start one recording
 * a minute: the first stall's, whose 5 s tail spans the loss at 2 s.
 */
static void test_lost_amid_overruns_named_lost(void **state)
{
	char dir[512], inc[600], names[64][DIR_NAME_MAX];
	struct timespec stall = { .tv_sec = 0, .tv_nsec = 30 * 1000000 };
	struct timespec between = { .tv_sec = 0, .tv_nsec = 170 * 1000000 };
	struct kid *k;
	unsigned n, lost = 0, folded = 0;
	bool other_first = false;

	(void)state;
	k = start_faults(
		"amid", dir, sizeof(dir), inc, sizeof(inc),
		"seconds_before: 0.3, seconds_after: 5, overrun_burst: 20",
		"        - {kind: disappear, motor: 3, start_s: 2, end_s: 300, param: 1}\n");
	/* stalls every 200 ms (shorter than the comm-loss time) until the loss is recorded */
	for (int ms = 0; !lost_recorded(k->out); ms += 200) {
		if (ms > INCIDENT_MS)
			fail_msg("no -lost recording in %d ms:\n%s", ms, kid_tail(k));
		self_fifo(SELF_FIFO_PRIO); /* each stall as long as asked on a busy machine */
		assert_int_equal(kill(k->pid, SIGSTOP), 0);
		if (!pid_wait_stopped(k->pid, START_MS))
			fail_msg("rmdd not stopped %d ms after SIGSTOP", START_MS);
		nanosleep(&stall, NULL);
		assert_int_equal(kill(k->pid, SIGCONT), 0);
		self_fifo(0);
		nanosleep(&between, NULL);
		kid_read(k);
	}
	stop(k);

	/* whichever recording holds the loss as a trigger is named after it */
	n = recordings(inc, names, 64);
	for (unsigned i = 0; i < n; i++) {
		char p[1024], what[256], *summary;
		struct ev ev[64];
		double before, own_from;
		unsigned m, lead;

		snprintf(p, sizeof(p), "%s/%.300s/summary.txt", inc, names[i]);
		summary = slurp(p);
		m = summary_events(summary, ev, 64);
		/*
		 * Its own triggers come from seconds_before past the window's start on;
		 * before that, a trigger was an earlier recording's (its tail read it).
		 */
		assert_non_null(strstr(summary, "Window:  "));
		assert_int_equal(sscanf(strstr(summary, "Window:  "), "Window: %lf", &before), 1);
		own_from = 0.3 - before - 1e-6;
		for (unsigned j = 0; j < m; j++) {
			if (!ev[j].trigger || ev[j].t_s < own_from ||
			    !strstr(ev[j].text, "motor 3 (c): ready -> lost"))
				continue;
			if (!strstr(names[i], "-lost"))
				fail_msg("%s holds the loss but is named as if it did not:\n%s",
					 names[i], summary);
			/*
			 * named after its first own trigger that is not an overrun: this
			 * loss, unless a busy machine lost another motor just before it
			 */
			for (lead = 0; lead < j; lead++)
				if (ev[lead].trigger && ev[lead].t_s >= own_from &&
				    !strstr(ev[lead].text, "overrun"))
					break;
			snprintf(what, sizeof(what), "What:    %s\n", ev[lead].text);
			assert_has(summary, what, p);
			assert_true(ev[lead].t_s == 0.0);
			other_first = lead != j;
			if (other_first)
				print_message("busy machine: %s (the recording's name) came before "
					      "motor 3's loss\n",
					      ev[lead].text);
			lost++;
			/* an overrun before it, in the same recording: the fold happened */
			for (unsigned e = 0; e < j; e++)
				folded += ev[e].trigger && ev[e].t_s >= own_from &&
					  strstr(ev[e].text, "overrun") != NULL;
		}
		free(summary);
	}
	assert_int_equal(lost, 1);
	if (folded && !other_first)
		assert_has(k->out, "-lost: sim0: motor 3 (c): ready -> lost, and ", "rmdd's log");
	print_message("%u recordings; the loss %s\n", n,
		      folded ? "came inside an overrun's tail and named its recording" :
			       "fell between two overrun recordings (nothing to fold this run)");
}

static int group_setup(void **state)
{
	(void)state;
	if (find_prog(rmdd, sizeof(rmdd), "RMDD", "rmdd") < 0 ||
	    find_prog(rmdctl, sizeof(rmdctl), "RMDCTL", "rmdctl") < 0)
		return -1;
	snprintf(tmpdir, sizeof(tmpdir), "/tmp/rmd-test-incidents-XXXXXX");
	return mkdtemp(tmpdir) ? 0 : -1;
}

static int group_teardown(void **state)
{
	(void)state;
	kid_kill_all();
	return rm_tree(tmpdir);
}

static int teardown(void **state)
{
	(void)state;
	kid_kill_all();
	return 0;
}

int main(void)
{
	const struct CMUnitTest tests[] = {
		cmocka_unit_test_teardown(test_lost_fault_and_bus_off_recorded, teardown),
		cmocka_unit_test_teardown(test_found_dialect_named, teardown),
		cmocka_unit_test_teardown(test_overrun_burst_goes_to_the_state_directory, teardown),
		cmocka_unit_test_teardown(test_overruns_recorded_once_a_minute, teardown),
		cmocka_unit_test_teardown(test_keep_bounds_the_recordings, teardown),
		cmocka_unit_test_teardown(test_lost_amid_overruns_named_lost, teardown),
	};

	cmocka_set_test_filter(getenv("RMD_TEST_FILTER"));
	return cmocka_run_group_tests_name("incidents", tests, group_setup, group_teardown);
}
