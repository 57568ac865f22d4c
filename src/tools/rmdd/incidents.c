// SPDX-License-Identifier: MIT
/*
 * rmdd's incident writer (docs/design.md "Incidents"): after a safety
 * event, the last seconds of every bus's frames (candump -l), the motors'
 * states and the commands the loop took, and a one-page summary, in a new
 * directory; the oldest recordings beyond incidents.keep are removed.
 *
 * The rt loop copies everything into an rmd_incident_ring as it goes
 * (rmd/incident.h).  The monitor thread, woken by the loop's event
 * hand-over, and the bridge, which rejects intruding controllers, call
 * rmdd_incidents_trigger(); this normal-priority thread then waits for
 * the tail (seconds_after, one timed wait for that event, no polling),
 * copies the window out of the ring and writes the files.  Triggers that
 * come while it waits belong to the same recording.  Overruns alone make at
 * most one recording a RMDD_INCIDENT_OVERRUN_HOLDOFF_S.  Everything here is
 * non-rt.
 */
#define _GNU_SOURCE /* pthread_setname_np */
#include <dirent.h>
#include <errno.h>
#include <fcntl.h>
#include <inttypes.h>
#include <limits.h>
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <time.h>
#include <unistd.h>

#include <sys/stat.h>

#include <lcm/eventlog.h>

#include "rmd/bridge.h"
#include "rmd/channels.h"
#include "rmd/dialect.h"
#include "rmd/rmd_command_t.h"
#include "rmd/rmd_state_t.h"
#include "rmd/motor.h"
#include "rmd/thread.h"
#include "rmd/time.h"
#include "rmdd.h"

/* Lines of the summary's "what happened" list: one page. */
#define SUMMARY_EVENTS 40

#define LOG_ENC_MAX 16384 /* state_t of 32 motors: some 3.5 kB */

/* ---- where the recordings go ---------------------------------------------- */

/* mkdir -p path (mode 0750).  0 or -errno. */
static int mkdir_p(const char *path)
{
	char tmp[PATH_MAX];
	size_t n = strlen(path);

	if (n == 0 || n >= sizeof(tmp))
		return -ENAMETOOLONG;
	memcpy(tmp, path, n + 1);
	for (char *p = tmp + 1; *p; p++) {
		if (*p != '/')
			continue;
		*p = '\0';
		if (mkdir(tmp, 0750) < 0 && errno != EEXIST)
			return -errno;
		*p = '/';
	}
	if (mkdir(tmp, 0750) < 0 && errno != EEXIST)
		return -errno;
	return 0;
}

void rmdd_incidents_dir(const struct rmd_config *cfg, char *out, size_t len)
{
	const char *s;

	if (cfg->incidents.dir[0])
		snprintf(out, len, "%s", cfg->incidents.dir);
	else if ((s = getenv("STATE_DIRECTORY")) && *s) /* systemd StateDirectory=rmdd */
		snprintf(out, len, "%.*s/incidents", (int)strcspn(s, ":"), s);
	else if ((s = getenv("XDG_STATE_HOME")) && *s == '/')
		snprintf(out, len, "%s/rmdd/incidents", s);
	else if ((s = getenv("HOME")) && *s == '/')
		snprintf(out, len, "%s/.local/state/rmdd/incidents", s);
	else
		snprintf(out, len, "rmdd-incidents");
}

/* A recording's directory name: "YYYYMMDD-HHMMSS-..." (what keep_bound() counts). */
static bool is_recording(const char *name)
{
	for (unsigned k = 0; k < 15; k++)
		if (k == 8 ? name[k] != '-' : (name[k] < '0' || name[k] > '9'))
			return false;
	return name[15] == '-';
}

static int name_cmp(const void *a, const void *b)
{
	return strcmp(*(char *const *)a, *(char *const *)b);
}

/* Remove dir/name and the files in it. */
static void remove_recording(const char *dir, const char *name)
{
	char path[PATH_MAX];
	struct dirent *de;
	DIR *d;

	snprintf(path, sizeof(path), "%s/%s", dir, name);
	d = opendir(path);
	if (!d)
		return;
	while ((de = readdir(d))) {
		if (de->d_name[0] == '.')
			continue;
		unlinkat(dirfd(d), de->d_name, 0);
	}
	closedir(d);
	rmdir(path);
}

/* Keep the newest `keep` recordings under dir (names sort by time). */
static void keep_bound(const char *dir, unsigned keep)
{
	char **names = NULL;
	size_t n = 0, cap = 0;
	struct dirent *de;
	DIR *d = opendir(dir);

	if (!d)
		return;
	while ((de = readdir(d))) {
		if (!is_recording(de->d_name))
			continue;
		if (n == cap) {
			char **nn = realloc(names, (cap ? cap * 2 : 32) * sizeof(*names));

			if (!nn)
				break;
			names = nn;
			cap = cap ? cap * 2 : 32;
		}
		names[n] = strdup(de->d_name);
		if (names[n])
			n++;
	}
	closedir(d);
	if (n > keep) {
		qsort(names, n, sizeof(*names), name_cmp);
		for (size_t k = 0; k < n - keep; k++)
			remove_recording(dir, names[k]);
	}
	for (size_t k = 0; k < n; k++)
		free(names[k]);
	free(names);
}

/* ---- what the files say ---------------------------------------------------- */

/* CLOCK_MONOTONIC ns -> CLOCK_REALTIME ns, by the offset measured now. */
static int64_t wall_offset_ns(void)
{
	struct timespec rt;

	clock_gettime(CLOCK_REALTIME, &rt);
	return (int64_t)rt.tv_sec * RMD_NS_PER_S + rt.tv_nsec - rmd_now_ns();
}

/* "2026-11-24 02:30:12.345678 UTC" */
static void utc_text(int64_t wall_ns, char *buf, size_t len)
{
	time_t s = (time_t)(wall_ns / RMD_NS_PER_S);
	struct tm tm;
	char d[32];

	gmtime_r(&s, &tm);
	strftime(d, sizeof(d), "%Y-%m-%d %H:%M:%S", &tm);
	snprintf(buf, len, "%s.%06ld UTC", d, (long)(wall_ns % RMD_NS_PER_S / 1000));
}

/* The candump interface name of bus b: its netdev for SocketCAN, else its name (15 chars). */
static void iface_of(const struct rmd_config *cfg, unsigned b, char out[16])
{
	const struct rmd_config_bus *cb = &cfg->buses[b];

	snprintf(out, 16, "%s", cb->interface[0] ? cb->interface : cb->name);
}

/*
 * The rmdctl decode protocol of bus b's motors: the key of the table the
 * dialects they were found to speak all share (MIT motors: V3's), else
 * "v3".
 */
static const char *decode_proto(const struct rmd_config *cfg, unsigned b)
{
	const struct rmd_dialect *t = NULL;

	for (unsigned i = 0; i < cfg->n_motors; i++) {
		const struct rmd_dialect *d = rmd_dialect(rmdd_motor_dialect(cfg, i));

		if (cfg->motors[i].bus != b || !d)
			continue;
		if (t && t != rmd_dialect_firmware(d))
			return "v3";
		t = rmd_dialect_firmware(d);
	}
	return t ? t->key : "v3";
}

/* ---- writing one recording ------------------------------------------------ */

struct item {
	int64_t t_ns;
	size_t order; /* events of one cycle share a time: they keep the loop's order */
	char text[200];
	bool trigger;
};

static int item_cmp(const void *a, const void *b)
{
	const struct item *x = a, *y = b;

	if (x->t_ns != y->t_ns)
		return (x->t_ns > y->t_ns) - (x->t_ns < y->t_ns);
	return (x->order > y->order) - (x->order < y->order);
}

/* What the files of one recording are written from. */
struct out {
	struct rmdd_incidents *in;
	const struct rmd_incident_window *w;
	const char *name; /* the folder's */
	const struct rmdd_trigger *trig;
	unsigned n_trig;
	int64_t from_ns, read_ns;	 /* the window */
	int64_t off_ns;			 /* CLOCK_MONOTONIC -> wall clock */
	unsigned bus;			 /* write_frames(): which */
	size_t tx[RMD_MAX_BUSES];	 /* write_frames(): frames sent, per bus */
	size_t log_states, log_commands; /* write_lcmlog(): state_t and command_t written */
	bool log_config;		 /* write_lcmlog(): the config_t too */
};

/* dir/name written by fn.  0, or -errno. */
static int write_file(const char *dir, const char *name, void (*fn)(FILE *f, struct out *o),
		      struct out *o)
{
	char path[PATH_MAX];
	FILE *f;

	if ((size_t)snprintf(path, sizeof(path), "%s/%s", dir, name) >= sizeof(path))
		return -ENAMETOOLONG;
	f = fopen(path, "w");
	if (!f)
		return -errno;
	fn(f, o);
	return fclose(f) ? -errno : 0;
}

static void write_frames(FILE *f, struct out *o)
{
	const struct rmd_incident_window *w = o->w;
	unsigned b = o->bus;
	size_t *tx = &o->tx[b];
	char iface[16];

	iface_of(o->in->cfg, b, iface);
	*tx = 0;
	/* one formatted prefix and the bytes by hand: a window holds some 100 k frames */
	for (size_t k = 0; k < w->n_frames[b]; k++) {
		static const char hex[] = "0123456789ABCDEF";
		const struct rmd_incident_frame *r = &w->frames[b][k];
		int64_t t = r->t_ns + o->off_ns;
		char line[128];
		int n = snprintf(line, sizeof(line),
				 "(%" PRId64 ".%06" PRId64 ") %s %03" PRIX32 "#", t / RMD_NS_PER_S,
				 t % RMD_NS_PER_S / 1000, iface, r->f.can_id);

		if (n < 0 || (size_t)n > sizeof(line) - 2 * RMD_FRAME_LEN - 4)
			continue;
		for (unsigned j = 0; j < r->f.len && j < RMD_FRAME_LEN; j++) {
			line[n++] = hex[r->f.data[j] >> 4];
			line[n++] = hex[r->f.data[j] & 15];
		}
		line[n++] = ' ';
		line[n++] = r->dir == RMD_INCIDENT_TX ? 'T' : 'R';
		line[n++] = '\n';
		fwrite(line, 1, (size_t)n, f);
		*tx += r->dir == RMD_INCIDENT_TX;
	}
}

static void write_states(FILE *f, struct out *o)
{
	const struct rmd_config *cfg = o->in->cfg;
	const struct rmd_incident_window *w = o->w;
	int64_t off_ns = o->off_ns;

	fprintf(f, "time_s,cycle,motor,name,lifecycle,mode,pos_rad,vel_rad_s,torque_nm,"
		   "current_a,temp_c,voltage_v,error_code,reply_age_cycles\n");
	for (size_t k = 0; k < w->n_states; k++) {
		const struct rmd_incident_state *s = &w->states[k];
		int64_t t = s->t_ns + off_ns;

		fprintf(f,
			"%" PRId64 ".%06" PRId64 ",%" PRIu64 ",%u,%s,%s,%s,%.6f,%.6f,%.4f,%.3f,"
			"%.1f,%.2f,0x%04X,%" PRIu32 "\n",
			t / RMD_NS_PER_S, t % RMD_NS_PER_S / 1000, s->cycle, s->motor,
			s->motor < cfg->n_motors ? cfg->motors[s->motor].name : "?",
			rmdd_lifecycle_name(s->lifecycle),
			s->mode < RMD_MODE_COUNT ? rmd_mode_names[s->mode] : "?", s->pos_rad,
			s->vel_rad_s, s->torque_nm, s->current_a, s->temp_c, s->voltage_v,
			s->error_code, s->reply_age_cycles);
	}
}

static void write_commands(FILE *f, struct out *o)
{
	const struct rmd_config *cfg = o->in->cfg;

	fprintf(f, "time_s,received_s,seq,motor,name,enable,mode,pos_rad,vel_rad_s,torque_nm,kp,"
		   "kd,max_vel_rad_s\n");
	for (size_t k = 0; k < o->w->n_commands; k++) {
		const struct rmd_incident_command *c = &o->w->commands[k];
		int64_t t = c->t_ns + o->off_ns, rx = c->rx_ns + o->off_ns;

		fprintf(f,
			"%" PRId64 ".%06" PRId64 ",%" PRId64 ".%06" PRId64 ",%" PRId64
			",%u,%s,%d,%s,%.6f,%.6f,%.4f,%.3f,%.3f,%.3f\n",
			t / RMD_NS_PER_S, t % RMD_NS_PER_S / 1000, rx / RMD_NS_PER_S,
			rx % RMD_NS_PER_S / 1000, c->seq, c->motor,
			c->motor < cfg->n_motors ? cfg->motors[c->motor].name : "?",
			c->sp.enable ? 1 : 0,
			c->sp.mode < RMD_MODE_COUNT ? rmd_mode_names[c->sp.mode] : "?",
			c->sp.pos_rad, c->sp.vel_rad_s, c->sp.torque_nm, c->sp.kp, c->sp.kd,
			c->sp.max_vel_rad_s);
	}
}

/* The events of the window and the triggers that came from outside the loop, in time order. */
static size_t merge_items(struct rmdd_incidents *in, const struct rmdd_trigger *trig,
			  unsigned n_trig, struct item *items, size_t cap)
{
	const struct rmd_incident_window *w = in->win;
	size_t n = 0;

	for (size_t k = 0; k < w->n_events && n < cap; k++) {
		const struct rmd_event *e = &w->events[k];
		char what[160];
		const char *kind;

		items[n].t_ns = e->t_ns;
		items[n].order = n;
		items[n].trigger = rmdd_incident_kind(in->cfg, e, what, sizeof(what), &kind);
		rmdd_event_summary(in->cfg, e, items[n].text, sizeof(items[n].text));
		n++;
	}
	for (unsigned k = 0; k < n_trig && n < cap; k++) {
		if (!trig[k].outside)
			continue;
		items[n].t_ns = trig[k].t_ns;
		items[n].order = n;
		items[n].trigger = true;
		snprintf(items[n].text, sizeof(items[n].text), "%s", trig[k].what);
		n++;
	}
	qsort(items, n, sizeof(*items), item_cmp);
	return n;
}

static void write_summary(FILE *f, struct out *o)
{
	struct rmdd_incidents *in = o->in;
	const char *name = o->name;
	const struct rmdd_trigger *trig = o->trig;
	unsigned n_trig = o->n_trig;
	int64_t from_ns = o->from_ns, read_ns = o->read_ns, off_ns = o->off_ns;
	const size_t *tx = o->tx;
	const struct rmd_config *cfg = in->cfg;
	const struct rmd_incident_window *w = in->win;
	size_t cap = w->cap_events + n_trig, n, shown = 0;
	struct item *items = calloc(cap, sizeof(*items));
	char when[64];
	int64_t t0 = trig[0].t_ns;

	utc_text(t0 + off_ns, when, sizeof(when));
	fprintf(f, "rmdd incident %s\n\n", name);
	fprintf(f, "What:    %s\n", trig[0].what);
	fprintf(f, "When:    %s (CLOCK_MONOTONIC %.6f s)\n", when, (double)t0 / 1e9);
	fprintf(f, "Window:  %.3f s before to %.3f s after it%s\n", (double)(t0 - from_ns) / 1e9,
		(double)(read_ns - t0) / 1e9,
		read_ns - t0 < (int64_t)(cfg->incidents.seconds_after * 1e9) ?
			" (rmdd stopped: a shorter tail)" :
			"");
	fprintf(f, "Config:  %s, %u Hz, %u motor(s) on %u bus(es)\n", cfg->source,
		cfg->loop.rate_hz, cfg->n_motors, cfg->n_buses);
	fprintf(f, "\nWhat happened, in order (seconds from When; * a trigger):\n");
	n = items ? merge_items(in, trig, n_trig, items, cap) : 0;
	for (size_t k = 0; k < n; k++) {
		/* one page: the triggers always, the other events while there is room */
		if (!items[k].trigger && shown >= SUMMARY_EVENTS)
			continue;
		fprintf(f, "  %+11.6f %c %s\n", (double)(items[k].t_ns - t0) / 1e9,
			items[k].trigger ? '*' : ' ', items[k].text);
		shown++;
	}
	if (shown < n)
		fprintf(f, "  (%zu more events not shown)\n", n - shown);
	if (!n)
		fprintf(f, "  (no events)\n");
	fprintf(f, "\nFiles (times are wall-clock seconds, as candump -l writes them):\n");
	for (unsigned b = 0; b < w->n_buses; b++) {
		char iface[16];

		iface_of(cfg, b, iface);
		fprintf(f,
			"  frames-%s.log  %zu frames on bus %s (%zu sent T, %zu received R), "
			"candump -l; rmdctl decode --protocol %s frames-%s.log\n",
			cfg->buses[b].name, w->n_frames[b], cfg->buses[b].name, tx[b],
			w->n_frames[b] - tx[b], decode_proto(cfg, b), cfg->buses[b].name);
	}
	fprintf(f, "  states.csv  %zu rows: each motor's state after each cycle\n", w->n_states);
	fprintf(f, "  commands.csv  %zu rows: each motor's entry of each command the loop took\n",
		w->n_commands);
	fprintf(f,
		"  window.lcmlog  an LCM log: %s%zu state_t on %s" RMD_CHANNEL_STATE
		", %zu command_t the loop took on %s" RMD_CHANNEL_COMMAND_TAKEN
		"; rmd-plot --log, lcm-logplayer, rmd-spy\n",
		o->log_config ? "config_t, " : "", o->log_states, cfg->lcm.channel_prefix,
		o->log_commands, cfg->lcm.channel_prefix);
	free(items);
}

/* ---- the window as an LCM log ------------------------------------------------ */

struct lcmlog {
	lcm_eventlog_t *log;
	int64_t n;
	int err;
	unsigned char *enc;
};

static void log_put(struct lcmlog *l, const char *prefix, const char *name, int64_t wall_ns,
		    int len)
{
	char channel[RMD_CONFIG_PREFIX_LEN + 32];
	lcm_eventlog_event_t ev = { 0 };

	if (l->err || len <= 0) {
		l->err = l->err ? l->err : -EOVERFLOW;
		return;
	}
	snprintf(channel, sizeof(channel), "%s%s", prefix, name);
	ev.eventnum = l->n++;
	ev.timestamp = wall_ns / 1000; /* as lcm-logger stamps: wall-clock microseconds */
	ev.channellen = (int32_t)strlen(channel);
	ev.channel = channel;
	ev.datalen = len;
	ev.data = l->enc;
	if (lcm_eventlog_write_event(l->log, &ev) != 0)
		l->err = -EIO;
}

/*
 * One state_t from the window's states[k..] of one cycle, as the bridge
 * publishes it (rmd_bridge_motor_state()) but from what the recorder keeps:
 * the receive times and counts the recorder does not hold are 0
 * (docs/faults.md "Incidents").
 * Returns the index after the cycle.
 */
static size_t log_state(struct lcmlog *l, struct out *o, size_t k, rmd_motor_state_t *ms)
{
	const struct rmd_incident_window *w = o->w;
	const struct rmd_incident_state *s0 = &w->states[k];
	rmd_state_t st = { .utime = s0->t_ns / 1000, .cycle = (int64_t)s0->cycle, .motor = ms };
	size_t j = k;

	for (; j < w->n_states && w->states[j].cycle == s0->cycle && st.count < RMD_MAX_MOTORS;
	     j++) {
		const struct rmd_incident_state *s = &w->states[j];
		/* what the recorder keeps of the motor's state (the rest is 0) */
		const struct rmd_motor_state m = {
			.lifecycle = s->lifecycle,
			.mode = s->mode,
			.pos_rad = s->pos_rad,
			.vel_rad_s = s->vel_rad_s,
			.torque_nm = s->torque_nm,
			.current_a = s->current_a,
			.temp_c = s->temp_c,
			.voltage_v = s->voltage_v,
			.error_code = s->error_code,
			.reply_age_cycles = s->reply_age_cycles,
		};

		rmd_bridge_motor_state(&ms[st.count++], s->motor, &m, s0->t_ns);
	}
	log_put(l, o->in->cfg->lcm.channel_prefix, RMD_CHANNEL_STATE, s0->t_ns + o->off_ns,
		rmd_state_t_encode(l->enc, 0, LOG_ENC_MAX, &st));
	o->log_states++;
	return j;
}

/* One command_t from the window's commands[k..] the loop took in one cycle from one message. */
static size_t log_command(struct lcmlog *l, struct out *o, size_t k, rmd_motor_command_t *mc)
{
	const struct rmd_incident_window *w = o->w;
	const struct rmd_incident_command *c0 = &w->commands[k];
	rmd_command_t cmd = { .utime = (c0->rx_ns ? c0->rx_ns : c0->t_ns) / 1000,
			      .seq = c0->seq,
			      .motor = mc };
	size_t j = k;

	for (; j < w->n_commands && w->commands[j].t_ns == c0->t_ns &&
	       w->commands[j].seq == c0->seq && cmd.count < RMD_MAX_MOTORS;
	     j++) {
		const struct rmd_incident_command *c = &w->commands[j];

		mc[cmd.count++] = (rmd_motor_command_t){
			.index = c->motor,
			.enable = c->sp.enable,
			.mode = (int8_t)c->sp.mode,
			.position = c->sp.pos_rad,
			.velocity = c->sp.vel_rad_s,
			.torque = c->sp.torque_nm,
			.kp = c->sp.kp,
			.kd = c->sp.kd,
			.max_velocity = c->sp.max_vel_rad_s,
		};
	}
	log_put(l, o->in->cfg->lcm.channel_prefix, RMD_CHANNEL_COMMAND_TAKEN, c0->t_ns + o->off_ns,
		rmd_command_t_encode(l->enc, 0, LOG_ENC_MAX, &cmd));
	o->log_commands++;
	return j;
}

/*
 * dir/window.lcmlog: config_t (the bridge's newest), then the window's
 * state_t and command_t in time order, so rmd-plot --log, lcm-logplayer
 * and rmd-spy open a recording as they open lcm-logger's logs.  0 or -errno.
 */
static int write_lcmlog(const char *dir, struct out *o)
{
	const struct rmd_incident_window *w = o->w;
	rmd_motor_state_t ms[RMD_MAX_MOTORS];
	rmd_motor_command_t mc[RMD_MAX_MOTORS];
	struct lcmlog l = { 0 };
	char path[PATH_MAX];
	size_t ks = 0, kc = 0;
	int n;

	if ((size_t)snprintf(path, sizeof(path), "%s/window.lcmlog", dir) >= sizeof(path))
		return -ENAMETOOLONG;
	l.enc = malloc(LOG_ENC_MAX);
	l.log = l.enc ? lcm_eventlog_create(path, "w") : NULL;
	if (!l.log) {
		free(l.enc);
		return l.enc ? -EIO : -ENOMEM;
	}
	n = o->in->bridge ? rmd_bridge_config_copy(o->in->bridge, l.enc, LOG_ENC_MAX) : 0;
	if (n > 0) {
		int64_t t = w->n_states ? w->states[0].t_ns : o->from_ns;

		log_put(&l, o->in->cfg->lcm.channel_prefix, RMD_CHANNEL_CONFIG, t + o->off_ns, n);
		o->log_config = true;
	}
	while (!l.err && (ks < w->n_states || kc < w->n_commands)) {
		if (kc < w->n_commands &&
		    (ks == w->n_states || w->commands[kc].t_ns <= w->states[ks].t_ns))
			kc = log_command(&l, o, kc, mc);
		else
			ks = log_state(&l, o, ks, ms);
	}
	lcm_eventlog_destroy(l.log);
	free(l.enc);
	return l.err;
}

/* Create "<dir>/<stamp>-<kind>[-N]"; its name into name.  0 or -errno. */
static int make_dir(const char *dir, int64_t wall_ns, const char *kind, char *name, size_t nlen,
		    char *path, size_t plen)
{
	time_t s = (time_t)(wall_ns / RMD_NS_PER_S);
	struct tm tm;
	char stamp[32];

	gmtime_r(&s, &tm);
	strftime(stamp, sizeof(stamp), "%Y%m%d-%H%M%S", &tm);
	for (unsigned k = 1; k < 100; k++) {
		if (k == 1)
			snprintf(name, nlen, "%s-%03ld-%s", stamp,
				 (long)(wall_ns % RMD_NS_PER_S / RMD_NS_PER_MS), kind);
		else
			snprintf(name, nlen, "%s-%03ld-%s-%u", stamp,
				 (long)(wall_ns % RMD_NS_PER_S / RMD_NS_PER_MS), kind, k);
		snprintf(path, plen, "%s/%s", dir, name);
		if (mkdir(path, 0750) == 0)
			return 0;
		if (errno != EEXIST)
			return -errno;
	}
	return -EEXIST;
}

/*
 * The trigger a recording is named after goes first: the first that is not an overrun.  A
 * loaded machine can overrun again and again; a motor lost in the middle of that must not be
 * filed under "overrun".  The others keep their order.
 */
static void lead_trigger(struct rmdd_trigger *trig, unsigned n)
{
	struct rmdd_trigger lead;
	unsigned k = 0;

	while (k < n && !strcmp(trig[k].kind, "overrun"))
		k++;
	if (k == 0 || k == n)
		return;
	lead = trig[k];
	memmove(&trig[1], &trig[0], k * sizeof(trig[0]));
	trig[0] = lead;
}

static int64_t first_trigger_ns(const struct rmdd_trigger *trig, unsigned n)
{
	int64_t t = trig[0].t_ns;

	for (unsigned k = 1; k < n; k++)
		if (trig[k].t_ns < t)
			t = trig[k].t_ns;
	return t;
}

/* Copy the window out of the ring and write it.  Writer thread. */
static void record(struct rmdd_incidents *in, const struct rmdd_trigger *trig, unsigned n_trig,
		   int64_t read_ns)
{
	static const struct {
		const char *file;
		void (*fn)(FILE *f, struct out *o);
	} files[] = {
		{ "states.csv", write_states },
		{ "commands.csv", write_commands },
		{ "summary.txt", write_summary }, /* last: a recording with a summary is whole */
	};
	const struct rmd_config *cfg = in->cfg;
	char name[96], path[PATH_MAX], more[48] = "";
	struct out o = {
		.in = in,
		.w = in->win,
		.name = name,
		.trig = trig,
		.n_trig = n_trig,
		.from_ns = first_trigger_ns(trig, n_trig) -
			   (int64_t)(cfg->incidents.seconds_before * 1e9),
		.read_ns = read_ns,
		.off_ns = wall_offset_ns(),
	};
	int r;

	rmd_incident_read(in->ring, o.from_ns, o.read_ns, in->win);
	r = mkdir_p(in->dir);
	if (r == 0)
		r = make_dir(in->dir, trig[0].t_ns + o.off_ns, trig[0].kind, name, sizeof(name),
			     path, sizeof(path));
	if (r < 0) {
		tool_log(3, "incident (%s): cannot create a directory under %s: %s", trig[0].what,
			 in->dir, strerror(-r));
		return;
	}
	for (o.bus = 0; o.bus < in->win->n_buses && r == 0; o.bus++) {
		char file[64];

		snprintf(file, sizeof(file), "frames-%s.log", cfg->buses[o.bus].name);
		r = write_file(path, file, write_frames, &o);
	}
	if (r == 0)
		r = write_lcmlog(path, &o);
	for (size_t k = 0; k < sizeof(files) / sizeof(files[0]) && r == 0; k++)
		r = write_file(path, files[k].file, files[k].fn, &o);
	if (r < 0) {
		tool_log(3, "incident (%s): writing %s: %s", trig[0].what, path, strerror(-r));
		return;
	}
	in->written++;
	if (n_trig > 1)
		snprintf(more, sizeof(more), ", and %u more trigger(s)", n_trig - 1);
	tool_log(5, "incident recorded in %s: %s%s (summary.txt says what happened)", path,
		 trig[0].what, more);
	keep_bound(in->dir, cfg->incidents.keep);
}

/* ---- the thread ------------------------------------------------------------- */

static void *writer_main(void *arg)
{
	struct rmdd_incidents *in = arg;
	int64_t after_ns = (int64_t)(in->cfg->incidents.seconds_after * 1e9);

	pthread_setname_np(pthread_self(), "rmdd-incident");
	pthread_mutex_lock(&in->mu);
	for (;;) {
		struct rmdd_trigger trig[RMDD_INCIDENT_TRIGGERS];
		unsigned n;
		int64_t read_ns, deadline;

		while (!in->stop && !in->n_trig)
			pthread_cond_wait(&in->cv, &in->mu);
		if (!in->n_trig)
			break;
		/* the tail: one timed wait until seconds_after past the first trigger */
		deadline = in->trig[0].t_ns + after_ns;
		while (!in->stop && rmd_now_ns() < deadline) {
			struct timespec ts = { .tv_sec = deadline / RMD_NS_PER_S,
					       .tv_nsec = deadline % RMD_NS_PER_S };

			pthread_cond_timedwait(&in->cv, &in->mu, &ts);
		}
		n = in->n_trig;
		memcpy(trig, in->trig, n * sizeof(trig[0]));
		lead_trigger(trig, n);
		in->n_trig = 0;
		read_ns = rmd_now_ns();
		/* what happened up to now is in this recording */
		in->covered_ns = read_ns;
		/* every trigger an overrun (lead_trigger() put any other first) */
		if (!strcmp(trig[0].kind, "overrun")) {
			in->overrun_quiet_ns =
				trig[0].t_ns +
				(int64_t)RMDD_INCIDENT_OVERRUN_HOLDOFF_S * RMD_NS_PER_S;
			in->overrun_held = false;
		}
		pthread_mutex_unlock(&in->mu);
		record(in, trig, n, read_ns);
		pthread_mutex_lock(&in->mu);
	}
	pthread_mutex_unlock(&in->mu);
	return NULL;
}

void rmdd_incidents_trigger(struct rmdd_incidents *in, int64_t t_ns, const char *kind,
			    const char *what, bool outside)
{
	bool held = false;

	if (!in || !in->ring)
		return;
	pthread_mutex_lock(&in->mu);
	if (!in->n_trig && t_ns < in->overrun_quiet_ns && !strcmp(kind, "overrun")) {
		/* said once a hold-off: the monitor's overrun lines count the rest */
		held = !in->overrun_held;
		in->overrun_held = true;
	} else if (t_ns > in->covered_ns && in->n_trig < RMDD_INCIDENT_TRIGGERS) {
		struct rmdd_trigger *t = &in->trig[in->n_trig++];

		t->t_ns = t_ns;
		t->outside = outside;
		snprintf(t->kind, sizeof(t->kind), "%s", kind);
		snprintf(t->what, sizeof(t->what), "%s", what);
		pthread_cond_signal(&in->cv);
	}
	pthread_mutex_unlock(&in->mu);
	if (held)
		tool_log(5,
			 "incident not recorded: %s (overruns alone make one recording every %d s "
			 "at most; the overrun lines count the rest)",
			 what, RMDD_INCIDENT_OVERRUN_HOLDOFF_S);
}

int rmdd_incidents_init(struct rmdd_incidents *in, const struct rmd_config *cfg,
			const struct rmd_plan *plan, char *err, size_t errlen)
{
	const struct rmd_config_incidents *ic = &cfg->incidents;
	pthread_condattr_t ca;
	int64_t window_ns = (int64_t)((ic->seconds_before + ic->seconds_after) * 1e9);

	memset(in, 0, sizeof(*in));
	in->cfg = cfg;
	in->covered_ns = INT64_MIN;
	in->overrun_quiet_ns = INT64_MIN;
	if (!ic->enabled)
		return 0;
	rmdd_incidents_dir(cfg, in->dir, sizeof(in->dir));
	in->ring = rmd_incident_ring_new(cfg, plan, window_ns, err, errlen);
	if (!in->ring)
		return -ENOMEM;
	in->win = rmd_incident_window_new(in->ring);
	if (!in->win) {
		rmd_incident_ring_free(in->ring);
		in->ring = NULL;
		snprintf(err, errlen, "incidents: out of memory");
		return -ENOMEM;
	}
	pthread_mutex_init(&in->mu, NULL);
	pthread_condattr_init(&ca);
	pthread_condattr_setclock(&ca, CLOCK_MONOTONIC);
	pthread_cond_init(&in->cv, &ca);
	pthread_condattr_destroy(&ca);
	in->inited = true;
	return 0;
}

int rmdd_incidents_start(struct rmdd_incidents *in)
{
	int r;

	if (!in->ring || in->running)
		return 0;
	r = rmd_thread_start_normal(&in->thread, writer_main, in);
	if (!r)
		in->running = true;
	return r;
}

void rmdd_incidents_stop(struct rmdd_incidents *in)
{
	if (!in->running)
		return;
	pthread_mutex_lock(&in->mu);
	in->stop = true;
	pthread_cond_signal(&in->cv);
	pthread_mutex_unlock(&in->mu);
	pthread_join(in->thread, NULL);
	in->running = false;
}

void rmdd_incidents_fini(struct rmdd_incidents *in)
{
	rmdd_incidents_stop(in);
	rmd_incident_window_free(in->win);
	rmd_incident_ring_free(in->ring);
	in->win = NULL;
	in->ring = NULL;
	if (in->inited) {
		pthread_cond_destroy(&in->cv);
		pthread_mutex_destroy(&in->mu);
		in->inited = false;
	}
}
