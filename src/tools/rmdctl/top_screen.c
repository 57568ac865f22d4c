// SPDX-License-Identifier: MIT
/*
 * rmdctl top on a terminal: the operator's screen, drawn with ncurses.
 *
 *   rmdctl top  [PAUSED]  [STALE ...]  12 motors  1 needs attention  cycle ...
 *   wake-up us avg, p99, max; overruns; plan misses
 *   watchdog, owner, commands accepted / rejected / clamped
 *   one line per bus: kind, state, load, frames, errors
 *      NAME     ID STATE   MODE ... PROT          <- the motor table
 *   >! knee_l    1 FAULT   ...                    <- one line per motor
 *   knee_l: the picked motor's details, on up to two lines
 *   q quit  p pause  ...                          <- the keys
 *
 * Several daemons of one robot (--prefix A_,B_): the title counts them,
 * one line per instance (its rate, wake-up p99, watchdog, buses; SILENT
 * when its health stopped) replaces the loop, watchdog and bus lines, and
 * the table's first column, INST, says each motor's instance.
 *
 * Nothing wraps: the motor table keeps the columns that fit the width,
 * dropping or narrowing the less urgent ones first (shrink[] below), and
 * the other lines are lists of items that leave out what does not fit.
 * When the motors do not fit the height, the table scrolls to the picked
 * one.  States that need attention get a mark ('!'), upper case and a
 * colour (red: FAULT, LOST, SAFE, error flags, a bus not active, a tripped
 * watchdog; yellow: STALE and comm-loss protection not armed), so that a
 * monochrome terminal shows them too.  Non-rt.
 */
#include <ctype.h>
#include <curses.h>
#include <inttypes.h>
#include <math.h>
#include <stdarg.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "rmd/frame.h"
#include "rmd/time.h"
#include "top_screen.h"
#include "tools/common/names.h"

#define NAME_MIN 4 /* the NAME column: from the longest name, within these */
#define NAME_MAX 16
#define DETAIL_ROWS 2 /* the picked motor's details */
#define ITEM_LEN 96
#define MAX_ITEMS 24

enum att { ATT_NONE, ATT_OK, ATT_WARN, ATT_ALARM };
enum { PAIR_OK = 1, PAIR_WARN, PAIR_ALARM };

/* The motor table's columns, in screen order. */
enum col {
	C_INST,
	C_IDX,
	C_NAME,
	C_BUS,
	C_ID,
	C_STATE,
	C_MODE,
	C_POS,
	C_VEL,
	C_TORQUE,
	C_TEMP,
	C_ERR,
	C_LAT,
	C_AGE,
	C_MISSED,
	C_PROT,
	NCOLS
};

static const struct {
	const char *head;
	int width; /* on a wide terminal (NAME: from the names) */
	bool left; /* text; numbers are right-aligned */
	int prec;  /* numbers (number()): decimals, fewer when the width needs it */
} cols[NCOLS] = {
	[C_INST] = { "INST", 0, true },	     [C_IDX] = { "IDX", 3, false },
	[C_NAME] = { "NAME", 12, true },     [C_BUS] = { "BUS", 8, true },
	[C_ID] = { "ID", 3, false },	     [C_STATE] = { "STATE", 7, true },
	[C_MODE] = { "MODE", 8, true },	     [C_POS] = { "POS", 8, false, 3 },
	[C_VEL] = { "VEL", 8, false, 3 },    [C_TORQUE] = { "TORQ", 7, false, 2 },
	[C_TEMP] = { "TEMP", 4, false, 0 },  [C_ERR] = { "ERR", 4, false },
	[C_LAT] = { "LAT_US", 6, false },    [C_AGE] = { "AGE_MS", 6, false, 1 },
	[C_MISSED] = { "MISSED", 6, false }, [C_PROT] = { "PROT", 11, true },
};

/*
 * How the table fits a narrower terminal, step by step until it fits: a
 * column dropped (width 0) or narrowed.  What the details line repeats
 * (reply latency and age, missed replies, bus, index) goes first, then
 * temperature and torque; names are cut only after that, as they are how
 * the operator knows a motor; state, mode and position stay longest.  At
 * 80 columns, names of up to 8 characters keep NAME ID STATE MODE POS VEL
 * TORQ TEMP ERR PROT; names of 12 lose TEMP.
 */
static const struct {
	enum col col;
	int width;
} shrink[] = {
	{ C_LAT, 0 },  { C_AGE, 0 },	{ C_MISSED, 0 }, { C_BUS, 0 },	{ C_IDX, 0 },
	{ C_TEMP, 0 }, { C_TORQUE, 0 }, { C_PROT, 7 },	 { C_NAME, 8 }, { C_ERR, 0 },
	{ C_VEL, 0 },  { C_ID, 0 },	{ C_MODE, 0 },	 { C_POS, 0 },	{ C_PROT, 0 },
};

#define MARK_W 3   /* '>' picked, '!' needs attention, a space */
#define INST_MAX 8 /* the INST column (several instances): from the longest prefix, at most */

struct top_screen {
	SCREEN *scr;
	bool colour;
	int sel, first; /* the picked motor, the table's first line */
	int width[NCOLS];
};

/* One piece of a line of items. */
struct item {
	char text[ITEM_LEN];
	enum att att;
};

struct items {
	struct item it[MAX_ITEMS];
	int n;
};

static void add(struct items *l, enum att att, const char *fmt, ...)
	__attribute__((format(printf, 3, 4)));

static void add(struct items *l, enum att att, const char *fmt, ...)
{
	va_list ap;

	if (l->n >= MAX_ITEMS)
		return;
	va_start(ap, fmt);
	vsnprintf(l->it[l->n].text, ITEM_LEN, fmt, ap);
	va_end(ap);
	l->it[l->n++].att = att;
}

/* A counter of health_t: its words and its value. */
struct count {
	const char *label;
	int64_t v;
};

/* Each of c[0..n-1] as "label N", plain. */
static void add_counts(struct items *l, const struct count *c, size_t n)
{
	for (size_t i = 0; i < n; i++)
		add(l, ATT_NONE, "%s %" PRId64, c[i].label, c[i].v);
}

static attr_t att_attr(const struct top_screen *u, enum att a)
{
	switch (a) {
	case ATT_NONE:
		return A_NORMAL;
	case ATT_OK:
		return u->colour ? COLOR_PAIR(PAIR_OK) : A_NORMAL;
	case ATT_WARN:
		return u->colour ? COLOR_PAIR(PAIR_WARN) | A_BOLD : A_UNDERLINE;
	case ATT_ALARM:
		return u->colour ? COLOR_PAIR(PAIR_ALARM) | A_BOLD : A_BOLD | A_UNDERLINE;
	}
	return A_NORMAL;
}

/* At most n characters of s at (y, x), clipped to the screen's width. */
static void put(int y, int x, const char *s, int n, attr_t attr)
{
	if (x >= COLS || y >= LINES || n <= 0)
		return;
	if (n > COLS - x)
		n = COLS - x;
	attrset(attr);
	mvaddnstr(y, x, s, n);
	attrset(A_NORMAL);
}

/* A whole row in attr (reverse video bars), blank. */
static void bar(int y, attr_t attr)
{
	attrset(attr);
	mvhline(y, 0, ' ', COLS);
	attrset(A_NORMAL);
}

/*
 * The items on rows y..y+rows-1, two spaces apart, each whole: one that
 * does not fit the rest of a row starts the next; one longer than a row is
 * left out.
 */
static void flow(const struct top_screen *u, int y, int rows, const struct items *l, attr_t base)
{
	int x = 0, row = 0;

	for (int i = 0; i < l->n && row < rows; i++) {
		int len = (int)strlen(l->it[i].text);

		if (len > COLS)
			continue;
		if (x && x + 2 + len > COLS) {
			if (row + 1 >= rows)
				continue; /* a shorter one may still fit this row */
			row++;
			x = 0;
		}
		if (x)
			x += 2;
		put(y + row, x, l->it[i].text, len, base | att_attr(u, l->it[i].att));
		x += len;
	}
}

/* v in at most width characters: fewer decimals when it is long, "#" when even 0 are too many. */
static const char *fit_num(char *buf, size_t size, int width, double v, int prec)
{
	if (!isfinite(v))
		return "-";
	for (int p = prec; p >= 0; p--) {
		snprintf(buf, size, "%.*f", p, v);
		if ((int)strlen(buf) <= width)
			return buf;
	}
	return "#";
}

/* The comm-loss protection is armed (0xB3 written and answered): the motor may be enabled. */
static bool armed(int cl)
{
	return cl == RMD_HEALTH_T_CL_ARMED || cl == RMD_HEALTH_T_CL_ARMED_ZEROS;
}

/* A comm-loss state in at most width characters: with its time when that fits. */
static const char *prot_text(char *buf, size_t size, int width, int cl, int ms)
{
	static const char *const brief[] = {
		[RMD_HEALTH_T_CL_PENDING] = "pending",	  [RMD_HEALTH_T_CL_ARMED] = "armed",
		[RMD_HEALTH_T_CL_ARMED_ZEROS] = "armed0", [RMD_HEALTH_T_CL_NO_ANSWER] = "noanswer",
		[RMD_HEALTH_T_CL_DIFFERS] = "differs",	  [RMD_HEALTH_T_CL_OFF] = "off",
		[RMD_HEALTH_T_CL_UNSUPPORTED] = "unsup",
	};
	const char *name = tool_comm_loss_name((unsigned)cl);

	snprintf(buf, size, "%s %dms", name, ms);
	if ((int)strlen(buf) <= width)
		return buf;
	if (cl >= 0 && cl < (int)(sizeof(brief) / sizeof(brief[0])))
		name = brief[cl];
	snprintf(buf, size, "%s %dms", name, ms);
	if ((int)strlen(buf) <= width)
		return buf;
	return name;
}

/* Upper case: states that need attention read so without colour too. */
static const char *upper(char *buf, size_t size, const char *s)
{
	size_t i;

	for (i = 0; s[i] && i + 1 < size; i++)
		buf[i] = (char)toupper((unsigned char)s[i]);
	buf[i] = '\0';
	return buf;
}

/* Motor i's lifecycle as the table shows it, and how urgent it is. */
static enum att motor_state_text(const struct top_view *t, const rmd_motor_state_t *ms, char *buf,
				 size_t size)
{
	if (top_stale(t)) {
		snprintf(buf, size, "STALE");
		return ATT_WARN;
	}
	switch (ms->lifecycle) {
	case RMD_STATE_T_LC_FAULT:
	case RMD_STATE_T_LC_LOST:
	case RMD_STATE_T_LC_SAFE:
		upper(buf, size, tool_lifecycle_name((unsigned)ms->lifecycle));
		return ATT_ALARM;
	case RMD_STATE_T_LC_ENABLED:
		snprintf(buf, size, "%s", tool_lifecycle_name((unsigned)ms->lifecycle));
		return ATT_OK;
	default:
		snprintf(buf, size, "%s", tool_lifecycle_name((unsigned)ms->lifecycle));
		return ATT_NONE;
	}
}

/* The value of motor state ms in numeric column c (POS, VEL, TORQ, TEMP, AGE_MS). */
static double number(const rmd_config_t *cf, const rmd_motor_state_t *ms, enum col c)
{
	const double v[NCOLS] = {
		[C_POS] = ms->position,
		[C_VEL] = ms->velocity,
		[C_TORQUE] = ms->torque,
		[C_TEMP] = ms->temperature,
		[C_AGE] = ms->reply_age_cycles * cf->period_us / 1000.0,
	};

	return v[c];
}

/* Cell c of motor i in at most width characters; returns how urgent it is. */
static enum att cell(const struct top_view *t, int i, enum col c, int width, char *buf, size_t size)
{
	const rmd_config_t *cf = t->cfg;
	const rmd_health_t *h = t->health;
	const rmd_motor_config_t *mc = &cf->motor[i];
	const rmd_motor_state_t *ms = top_motor_state(t, i);
	char num[32];
	enum att a = ATT_NONE;

	buf[0] = '\0';
	if (!ms && c != C_INST && c != C_IDX && c != C_NAME && c != C_BUS && c != C_ID) {
		if (c == C_STATE)
			snprintf(buf, size, "?");
		return c == C_STATE ? ATT_WARN : ATT_NONE;
	}
	switch (c) {
	case C_INST:
		snprintf(buf, size, "%s", top_instance_name(t));
		break;
	case C_IDX:
		snprintf(buf, size, "%d", i);
		break;
	case C_NAME:
		snprintf(buf, size, "%s", mc->name);
		break;
	case C_BUS:
		snprintf(buf, size, "%s",
			 mc->bus >= 0 && mc->bus < cf->bus_count ? cf->bus[mc->bus].name : "?");
		break;
	case C_ID:
		snprintf(buf, size, "%d", mc->id);
		break;
	case C_STATE:
		a = motor_state_text(t, ms, buf, size);
		break;
	case C_MODE:
		snprintf(buf, size, "%s", top_mode_name(ms->mode));
		break;
	case C_POS:
	case C_VEL:
	case C_TORQUE:
	case C_TEMP:
	case C_AGE:
		snprintf(buf, size, "%s",
			 fit_num(num, sizeof(num), width, number(cf, ms, c), cols[c].prec));
		break;
	case C_ERR:
		snprintf(buf, size, "%x", (unsigned)ms->error_code);
		a = ms->error_code ? ATT_ALARM : ATT_NONE;
		break;
	case C_LAT:
		snprintf(buf, size, "%d", ms->reply_latency_us);
		break;
	case C_MISSED:
		snprintf(buf, size, "%" PRId64, ms->missed_replies);
		break;
	case C_PROT:
		if (i >= h->motor_count) {
			snprintf(buf, size, "?");
			return ATT_WARN;
		}
		snprintf(buf, size, "%s",
			 prot_text(num, sizeof(num), width, h->comm_loss[i], h->comm_loss_ms[i]));
		a = armed(h->comm_loss[i]) ? ATT_NONE : ATT_WARN;
		break;
	case NCOLS:
		break;
	}
	return a;
}

/* How urgent motor i is: the most urgent of its cells. */
static enum att motor_att(const struct top_view *t, int i)
{
	static const enum col watched[] = { C_STATE, C_ERR, C_PROT };
	enum att worst = ATT_NONE;
	char buf[64];

	for (size_t k = 0; k < sizeof(watched) / sizeof(watched[0]); k++) {
		enum att a = cell(t, i, watched[k], 32, buf, sizeof(buf));

		if (a != ATT_OK && a > worst)
			worst = a;
	}
	return worst;
}

/*
 * The columns' widths for this terminal, for the motors of v[0..n-1]:
 * u->width[c], 0 when left out (INST with one instance).
 */
static void layout(const struct top_view *v, int n, struct top_screen *u)
{
	int total = MARK_W, name = NAME_MIN, inst = 0;

	for (int k = 0; k < n; k++) {
		int plen = (int)strlen(top_instance_name(&v[k]));

		if (n > 1 && plen > inst)
			inst = plen < INST_MAX ? plen : INST_MAX;
		for (int i = 0; v[k].cfg && i < v[k].cfg->motor_count; i++) {
			int len = (int)strlen(v[k].cfg->motor[i].name);

			if (len > name)
				name = len;
		}
	}
	if (inst && inst < (int)strlen(cols[C_INST].head))
		inst = (int)strlen(cols[C_INST].head);
	for (int c = 0; c < NCOLS; c++) {
		u->width[c] = c == C_NAME ? (name < NAME_MAX ? name : NAME_MAX) :
			      c == C_INST ? inst :
					    cols[c].width;
		if (u->width[c])
			total += u->width[c] + 1;
	}
	total--; /* no space after the last column */
	for (size_t s = 0; s < sizeof(shrink) / sizeof(shrink[0]) && total > COLS; s++) {
		int c = shrink[s].col, w = shrink[s].width;

		if (u->width[c] <= w)
			continue;
		total -= u->width[c] - w + (w == 0 && u->width[c] ? 1 : 0);
		u->width[c] = w;
	}
}

/* One table row (motor i of t, or the column heads when i < 0) at line y. */
static void table_row(const struct top_view *t, const struct top_screen *u, int y, int i,
		      bool picked)
{
	attr_t base = picked ? A_REVERSE : A_NORMAL;
	enum att worst = i >= 0 ? motor_att(t, i) : ATT_NONE;
	char mark[MARK_W + 1] = { picked ? '>' : ' ', worst >= ATT_WARN ? '!' : ' ', ' ', '\0' };
	int x = MARK_W;

	if (i < 0)
		base = A_BOLD;
	if (picked)
		bar(y, base);
	put(y, 0, mark, MARK_W, base | att_attr(u, worst));
	for (int c = 0; c < NCOLS; c++) {
		int w = u->width[c];
		char text[64], cellbuf[80];
		enum att a = ATT_NONE;

		if (!w)
			continue;
		if (i < 0)
			snprintf(text, sizeof(text), "%s", cols[c].head);
		else
			a = cell(t, i, c, w, text, sizeof(text));
		snprintf(cellbuf, sizeof(cellbuf), cols[c].left ? "%-*.*s" : "%*.*s", w, w, text);
		if (x > MARK_W)
			put(y, x - 1, " ", 1, base);
		put(y, x, cellbuf, w, base | att_attr(u, a));
		x += w + 1;
	}
}

static void title(const struct top_view *t, const struct top_screen *u, int y)
{
	struct items l = { .n = 0 };
	int64_t now = rmd_now_ns();

	add(&l, ATT_NONE, "rmdctl top");
	if (t->paused)
		add(&l, ATT_WARN, "PAUSED");
	/* another daemon on the prefix: both named; the view stays on the first */
	if (t->mixed)
		add(&l, ATT_ALARM,
		    "MIXED: 2 rmdd: shown %08" PRIx32 " %s pid %d, also %08" PRIx32 " %s pid %d",
		    (uint32_t)((uint64_t)t->instance >> 32),
		    t->cfg    ? t->cfg->host :
		    t->health ? t->health->host :
				"?",
		    t->cfg    ? (int)t->cfg->pid :
		    t->health ? (int)t->health->pid :
				0,
		    (uint32_t)((uint64_t)t->other_instance >> 32), t->other_host,
		    (int)t->other_pid);
	if (t->cfg && t->health && t->state) {
		enum att worst = ATT_NONE;
		int n = 0;

		if (top_stale(t)) {
			int64_t last = t->health_rx_ns < t->state_rx_ns ? t->health_rx_ns :
									  t->state_rx_ns;

			add(&l, ATT_WARN, "STALE: no health or state for %.1f s",
			    (double)(now - last) / 1e9);
		}
		for (int i = 0; i < t->cfg->motor_count; i++) {
			enum att a = motor_att(t, i);

			n += a >= ATT_WARN;
			if (a > worst)
				worst = a;
		}
		add(&l, ATT_NONE, "%d motors", t->cfg->motor_count);
		if (n)
			add(&l, worst, "%d need%s attention", n, n == 1 ? "s" : "");
		add(&l, ATT_NONE, "cycle %" PRId64, t->state->cycle);
		add(&l, ATT_NONE, "period %d us", t->cfg->period_us);
	}
	add(&l, ATT_NONE, "%s", t->url);
	add(&l, ATT_NONE, "prefix %s", t->prefix);
	bar(y, A_REVERSE);
	flow(u, y, 1, &l, A_REVERSE);
}

static void loop_line(const struct top_view *t, const struct top_screen *u, int y)
{
	const rmd_health_t *h = t->health;
	struct items l = { .n = 0 };
	char b[4][32];

	add(&l, ATT_NONE, "wake-up us avg %s p99 %s max %s",
	    fit_num(b[0], 32, 9, h->wake_avg_us, 1), fit_num(b[1], 32, 9, h->wake_p99_us, 1),
	    fit_num(b[2], 32, 9, h->wake_max_us, 1));
	add(&l, ATT_NONE, "overruns %" PRId64, h->overruns);
	add(&l, ATT_NONE, "plan misses %" PRId64, h->plan_misses);
	add(&l, ATT_NONE, "cycle max %s us", fit_num(b[3], 32, 9, h->cycle_max_us, 1));
	add(&l, ATT_NONE, "cycles %" PRId64, h->cycles);
	flow(u, y, 1, &l, A_NORMAL);
}

static void control_line(const struct top_view *t, const struct top_screen *u, int y)
{
	const rmd_health_t *h = t->health;
	struct items l = { .n = 0 };

	add(&l, h->watchdog == RMD_HEALTH_T_WD_TRIPPED ? ATT_ALARM : ATT_NONE, "watchdog %s",
	    tool_watchdog_name((unsigned)h->watchdog));
	if (h->owned)
		add(&l, ATT_NONE, "owner %" PRId64, h->owner);
	else
		add(&l, ATT_NONE, "no owner");
	add_counts(&l,
		   (const struct count[]){ { "commands", h->commands_accepted },
					   { "rejected", h->commands_rejected },
					   { "clamped", h->commands_clamped },
					   { "safe actions", h->safe_action_events } },
		   4);
	flow(u, y, 1, &l, A_NORMAL);
}

static void bus_line(const struct top_view *t, const struct top_screen *u, int y, int b)
{
	const rmd_bus_health_t *bh = &t->health->bus[b];
	struct items l = { .n = 0 };
	enum att a = bh->state == RMD_BUS_ACTIVE  ? ATT_NONE :
		     bh->state == RMD_BUS_WARNING ? ATT_WARN :
						    ATT_ALARM;

	add(&l, ATT_NONE, "%s (%s)", bh->name, b < t->cfg->bus_count ? t->cfg->bus[b].kind : "?");
	add(&l, a, "%s", top_bus_state_name(bh->state));
	add(&l, ATT_NONE, "load %.1f%%", bh->load * 100.0);
	add_counts(&l,
		   (const struct count[]){ { "tx", bh->tx_frames },
					   { "rx", bh->rx_frames },
					   { "tx busy", bh->tx_busy },
					   { "rx errors", bh->rx_errors },
					   { "bus errors", bh->bus_errors },
					   { "state changes", bh->state_changes } },
		   6);
	flow(u, y, 1, &l, A_NORMAL);
}

/* The picked motor (sel of t), everything the table has no room for. */
static void details(const struct top_view *t, const struct top_screen *u, int sel, int y, int rows)
{
	const rmd_config_t *c = t->cfg;
	const rmd_health_t *h = t->health;
	const rmd_motor_config_t *mc = &c->motor[sel];
	const rmd_motor_state_t *ms = top_motor_state(t, sel);
	struct items l = { .n = 0 };
	char b[32], st[32];

	add(&l, ATT_NONE, "%s: index %d, %s id %d, %s", mc->name, sel,
	    mc->bus >= 0 && mc->bus < c->bus_count ? c->bus[mc->bus].name : "?", mc->id,
	    mc->protocol);
	if (ms) {
		enum att a = motor_state_text(t, ms, st, sizeof(st));

		add(&l, a == ATT_OK ? ATT_NONE : a, "%s", st);
		add(&l, ATT_NONE, "mode %s", top_mode_name(ms->mode));
		add(&l, ATT_NONE, "%s rad", fit_num(b, sizeof(b), 12, ms->position, 4));
		add(&l, ATT_NONE, "%s rad/s", fit_num(b, sizeof(b), 12, ms->velocity, 3));
		add(&l, ATT_NONE, "%s N*m", fit_num(b, sizeof(b), 12, ms->torque, 3));
		add(&l, ATT_NONE, "%s A", fit_num(b, sizeof(b), 12, ms->current, 2));
		add(&l, ATT_NONE, "%s V", fit_num(b, sizeof(b), 12, ms->voltage, 1));
		add(&l, ATT_NONE, "%s degC", fit_num(b, sizeof(b), 12, ms->temperature, 0));
		add(&l, ms->error_code ? ATT_ALARM : ATT_NONE, "errors %#x",
		    (unsigned)ms->error_code);
		add(&l, ATT_NONE, "reply %d us, %s ms ago", ms->reply_latency_us,
		    fit_num(b, sizeof(b), 12, ms->reply_age_cycles * c->period_us / 1000.0, 1));
		add(&l, ATT_NONE, "missed %" PRId64, ms->missed_replies);
	}
	if (sel < h->motor_count) {
		add(&l, armed(h->comm_loss[sel]) ? ATT_NONE : ATT_WARN, "comm-loss %s %d ms",
		    tool_comm_loss_name((unsigned)h->comm_loss[sel]), h->comm_loss_ms[sel]);
		add(&l, ATT_NONE, "enables refused unarmed %" PRId64, h->unarmed_rejects[sel]);
	}
	flow(u, y, rows, &l, A_NORMAL);
}

static void footer(const struct top_screen *u, int y)
{
	struct items l = { .n = 0 };

	add(&l, ATT_NONE, "q quit");
	add(&l, ATT_NONE, "p pause");
	add(&l, ATT_NONE, "up/down j/k: motor");
	add(&l, ATT_NONE, "! needs attention");
	bar(y, A_REVERSE);
	flow(u, y, 1, &l, A_REVERSE);
}

/*
 * The whole screen.  Rows, most needed first: title, column heads and keys
 * always; then the loop line, the details and the motors, the watchdog
 * line and the buses, as many of each as the height leaves.
 */
static void draw_one(struct top_screen *u, const struct top_view *t)
{
	int y = 0, avail, n, lrows, mrows, drows, crow, brows;

	erase();
	title(t, u, y++);
	if (!t->cfg || !t->health || !t->state) {
		if (LINES > 2)
			mvprintw(y, 0, "%.*s", COLS, "waiting for rmdd ...");
		if (LINES > 3)
			mvprintw(y + 1, 0, "config %s, health %s, state %s", t->cfg ? "yes" : "no",
				 t->health ? "yes" : "no", t->state ? "yes" : "no");
		if (LINES > 1)
			footer(u, LINES - 1);
		refresh();
		return;
	}
	n = t->cfg->motor_count;
	if (u->sel >= n)
		u->sel = n - 1;
	if (u->sel < 0)
		u->sel = 0;
	avail = LINES - 3; /* title, column heads, keys */
	if (avail < 0)
		avail = 0;
	lrows = avail > 0 ? 1 : 0;
	avail -= lrows;
	/* the picked motor's details outrank table rows the height has no room for anyway */
	drows = n && avail >= DETAIL_ROWS + 3 ? DETAIL_ROWS : 0;
	mrows = n < avail - drows ? n : avail - drows;
	avail -= mrows + drows;
	crow = avail > 0 ? 1 : 0;
	avail -= crow;
	brows = t->health->bus_count < avail ? t->health->bus_count : avail;
	if (brows > RMD_HEALTH_T_MAX_BUSES)
		brows = RMD_HEALTH_T_MAX_BUSES;

	if (lrows)
		loop_line(t, u, y++);
	if (crow)
		control_line(t, u, y++);
	for (int b = 0; b < brows; b++)
		bus_line(t, u, y++, b);
	layout(t, 1, u);
	if (LINES > 2)
		table_row(t, u, y++, -1, false);
	/* the table scrolls to keep the picked motor in view */
	if (u->sel < u->first)
		u->first = u->sel;
	if (mrows && u->sel >= u->first + mrows)
		u->first = u->sel - mrows + 1;
	if (u->first > n - mrows)
		u->first = n - mrows;
	if (u->first < 0)
		u->first = 0;
	for (int k = 0; k < mrows; k++)
		table_row(t, u, y++, u->first + k, u->first + k == u->sel);
	if (drows)
		details(t, u, u->sel, y, drows);
	if (LINES > 1)
		footer(u, LINES - 1);
	refresh();
}

/* ---- several instances (--prefix A_,B_) ------------------------------------------------ */

/* The motors of v[0..n-1] that config_t named, counted through the instances in order. */
static int total_motors(const struct top_view *v, int n)
{
	int m = 0;

	for (int k = 0; k < n; k++)
		m += v[k].cfg ? v[k].cfg->motor_count : 0;
	return m;
}

/* Motor number j of that count: its instance *k and index *i. */
static void motor_at(const struct top_view *v, int n, int j, int *k, int *i)
{
	for (*k = 0; *k < n; (*k)++) {
		int m = v[*k].cfg ? v[*k].cfg->motor_count : 0;

		if (j < m)
			break;
		j -= m;
	}
	*i = j;
}

/* A whole instance's motors from it: complete enough to draw rows from. */
static bool drawable(const struct top_view *t)
{
	return t->cfg && t->health && t->state;
}

static void multi_title(const struct top_view *v, int n, const struct top_screen *u, int y)
{
	struct items l = { .n = 0 };
	int silent = 0, need = 0;
	enum att worst = ATT_NONE;

	add(&l, ATT_NONE, "rmdctl top");
	if (v[0].paused)
		add(&l, ATT_WARN, "PAUSED");
	for (int k = 0; k < n; k++) {
		silent += top_silent(&v[k]);
		for (int i = 0; drawable(&v[k]) && i < v[k].cfg->motor_count; i++) {
			enum att a = motor_att(&v[k], i);

			need += a >= ATT_WARN;
			if (a > worst)
				worst = a;
		}
	}
	add(&l, ATT_NONE, "%d instances", n);
	if (silent)
		add(&l, ATT_ALARM, "%d silent", silent);
	add(&l, ATT_NONE, "%d motors", total_motors(v, n));
	if (need)
		add(&l, worst, "%d need%s attention", need, need == 1 ? "s" : "");
	add(&l, ATT_NONE, "%s", v[0].url);
	bar(y, A_REVERSE);
	flow(u, y, 1, &l, A_REVERSE);
}

/* One instance's line: its prefix, SILENT, its rate, watchdog, buses and loop. */
static void instance_line(const struct top_view *t, const struct top_screen *u, int y)
{
	const rmd_health_t *h = t->health;
	struct items l = { .n = 0 };
	char b[32];

	add(&l, ATT_NONE, "%s", top_instance_name(t));
	if (top_silent(t)) {
		if (h)
			add(&l, ATT_ALARM, "SILENT: no health for %.1f s (rmdd lost?)",
			    (double)(rmd_now_ns() - t->health_rx_ns) / 1e9);
		else
			add(&l, ATT_WARN, "waiting: config %s, health no, state %s",
			    t->cfg ? "yes" : "no", t->state ? "yes" : "no");
	}
	if (t->mixed)
		add(&l, ATT_ALARM, "MIXED: 2 rmdd");
	if (!h)
		goto draw;
	if (t->cfg && t->cfg->period_us > 0)
		add(&l, ATT_NONE, "%.0f Hz", 1e6 / t->cfg->period_us);
	add(&l, h->watchdog == RMD_HEALTH_T_WD_TRIPPED ? ATT_ALARM : ATT_NONE, "watchdog %s",
	    tool_watchdog_name((unsigned)h->watchdog));
	for (int i = 0; i < h->bus_count && i < RMD_HEALTH_T_MAX_BUSES; i++) {
		const rmd_bus_health_t *bh = &h->bus[i];

		add(&l,
		    bh->state == RMD_BUS_ACTIVE	 ? ATT_NONE :
		    bh->state == RMD_BUS_WARNING ? ATT_WARN :
						   ATT_ALARM,
		    "%s %s %.0f%%", bh->name, top_bus_state_name(bh->state), bh->load * 100.0);
	}
	/* the cycles count shows a live daemon's line moving; what fits after it follows */
	add(&l, ATT_NONE, "cycles %" PRId64, h->cycles);
	add(&l, ATT_NONE, "p99 %s us", fit_num(b, sizeof(b), 9, h->wake_p99_us, 1));
	add(&l, h->overruns ? ATT_WARN : ATT_NONE, "overruns %" PRId64, h->overruns);
draw:
	flow(u, y, 1, &l, A_NORMAL);
}

/*
 * Rows, most needed first: title, column heads and keys; a line per
 * instance; the details and the motors of every instance (the table
 * scrolls to the picked one).
 */
static void draw_multi(struct top_screen *u, const struct top_view *v, int n)
{
	int y = 0, avail, m = total_motors(v, n), irows, mrows, drows, k, i;

	erase();
	multi_title(v, n, u, y++);
	if (u->sel >= m)
		u->sel = m - 1;
	if (u->sel < 0)
		u->sel = 0;
	avail = LINES - 3 > 0 ? LINES - 3 : 0; /* title, column heads, keys */
	irows = n < avail ? n : avail;
	avail -= irows;
	drows = m && avail >= DETAIL_ROWS + 3 ? DETAIL_ROWS : 0;
	mrows = m < avail - drows ? m : avail - drows;
	for (k = 0; k < irows; k++)
		instance_line(&v[k], u, y++);
	layout(v, n, u);
	if (LINES > 2)
		table_row(&v[0], u, y++, -1, false);
	if (u->sel < u->first)
		u->first = u->sel;
	if (mrows && u->sel >= u->first + mrows)
		u->first = u->sel - mrows + 1;
	if (u->first > m - mrows)
		u->first = m - mrows;
	if (u->first < 0)
		u->first = 0;
	for (int r = 0; r < mrows; r++) {
		motor_at(v, n, u->first + r, &k, &i);
		if (drawable(&v[k]))
			table_row(&v[k], u, y, i, u->first + r == u->sel);
		y++;
	}
	motor_at(v, n, u->sel, &k, &i);
	if (drows && m && drawable(&v[k]))
		details(&v[k], u, i, y, drows);
	if (LINES > 1)
		footer(u, LINES - 1);
	refresh();
}

void top_screen_draw(struct top_screen *u, const struct top_view *v, int n)
{
	if (n > 1)
		draw_multi(u, v, n);
	else
		draw_one(u, v);
}

unsigned int top_screen_keys(struct top_screen *u, const struct top_view *v, int n)
{
	unsigned int r = 0;
	int ch;

	while ((ch = getch()) != ERR) {
		switch (ch) {
		case 'q':
		case 'Q':
			r |= TOP_SCREEN_QUIT;
			break;
		case 'p':
		case ' ':
			r ^= TOP_SCREEN_PAUSE;
			break;
		case KEY_UP:
		case 'k':
			u->sel--;
			break;
		case KEY_DOWN:
		case 'j':
			u->sel++;
			break;
		case KEY_HOME:
		case 'g':
			u->sel = 0;
			break;
		case KEY_END:
		case 'G':
			u->sel = total_motors(v, n) > 0 ? total_motors(v, n) - 1 : 0;
			break;
		default: /* KEY_RESIZE too: curses has the new size, a redraw uses it */
			break;
		}
		r |= TOP_SCREEN_KEYED;
	}
	return r;
}

struct top_screen *top_screen_open(void)
{
	struct top_screen *u = calloc(1, sizeof(*u));

	if (!u)
		return NULL;
	/*
	 * newterm, not initscr: a terminal curses does not know is reported,
	 * not fatal.  rmdctl's SIGINT and SIGTERM handlers are in place, so
	 * curses keeps them (and adds its SIGWINCH one): Ctrl-C ends top's
	 * loop, and endwin() restores the terminal.
	 */
	u->scr = newterm(NULL, stdout, stdin);
	if (!u->scr) {
		free(u);
		return NULL;
	}
	set_term(u->scr);
	cbreak();
	noecho();
	keypad(stdscr, TRUE);
	nodelay(stdscr, TRUE);
	curs_set(0);
	if (has_colors() && start_color() == OK) {
		short bg = use_default_colors() == OK ? -1 : COLOR_BLACK;

		u->colour = true;
		init_pair(PAIR_OK, COLOR_GREEN, bg);
		init_pair(PAIR_WARN, COLOR_YELLOW, bg);
		init_pair(PAIR_ALARM, COLOR_RED, bg);
	}
	return u;
}

void top_screen_close(struct top_screen *u)
{
	endwin();
	delscreen(u->scr);
	free(u);
}
