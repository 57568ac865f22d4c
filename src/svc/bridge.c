// SPDX-License-Identifier: MIT
/*
 * The LCM bridge: the object and its thread.  The thread waits on the
 * link, the loop's snapshots and the health timer, drains what came and
 * hands each message on (commands and homes to admission.c), and has
 * state, health and configuration published when they are due
 * (publish.c); it also tells another daemon on the prefix.  See
 * rmd/bridge.h, bridge_state.h and docs/lcm.md.
 */
#define _GNU_SOURCE /* pthread_setname_np */

#include <ctype.h>
#include <errno.h>
#include <inttypes.h>
#include <limits.h>
#include <poll.h>
#include <sched.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <time.h>
#include <unistd.h>

#include <sys/epoll.h>
#include <sys/eventfd.h>
#include <sys/timerfd.h>

#include "rmd/time.h"
#include "rmd/thread.h"
#include "rmd/bridge.h"
#include "bridge_state.h"
#include "rmd/rmd_config_request_t.h"
#include "rmd/rmd_config_t.h"
#include "rmd/rmd_health_t.h"

/* Messages handled per wake-up at most, so the health timer is never starved. */
#define DRAIN_MAX 4096

/* Not udpm: queued messages LCM keeps for us before it drops (its default is 30). */
#define COMMAND_QUEUE 4096

/* config_t answers a flood of CONFIG_REQUESTs at most this often (each allocates). */
#define CONFIG_INTERVAL_NS (100 * RMD_NS_PER_MS)

void rmd_bridge_opts_init(struct rmd_bridge_opts *opts)
{
	memset(opts, 0, sizeof(*opts));
	snprintf(opts->url, sizeof(opts->url), "%s", RMD_CONFIG_DEFAULT_LCM_URL);
	snprintf(opts->prefix, sizeof(opts->prefix), "%s", RMD_CONFIG_DEFAULT_CHANNEL_PREFIX);
	opts->period_ns = 1000000;
	opts->state_every = 1;
	opts->stale_ms = RMD_CONFIG_DEFAULT_STALE_MS;
	opts->command_timeout_ms = RMD_CONFIG_DEFAULT_COMMAND_TIMEOUT_MS;
	opts->health_period_ns = (int64_t)RMD_CONFIG_DEFAULT_HEALTH_PERIOD_MS * RMD_NS_PER_MS;
	opts->poll_ns = RMD_BRIDGE_DEFAULT_POLL_NS;
	opts->notify_fd = -1;
	opts->robot.heartbeat_ms = RMD_CONFIG_DEFAULT_HEARTBEAT_MS;
	opts->robot.peer_timeout_ms = RMD_CONFIG_DEFAULT_PEER_TIMEOUT_MS;
	opts->robot.max_clock_offset_ms = RMD_CONFIG_DEFAULT_MAX_CLOCK_OFFSET_MS;
}

static void on_config_request(struct rmd_bridge *b)
{
	if (!b->probing)
		b->config_wanted = true;
}

/* ---- another daemon on the prefix (docs/lcm.md "One daemon per prefix") ---- */

/* A message of another daemon's arrived (instance 0: a state_t, which names nobody). */
static void note_foreign(struct rmd_bridge *b, int64_t instance, const char *host, int32_t pid,
			 const char *source)
{
	struct rmd_bridge_peer *f = &b->foreign;

	f->messages++;
	b->foreign_ns = rmd_now_ns();
	if (instance) {
		f->instance = instance;
		snprintf(f->host, sizeof(f->host), "%s", host ? host : "");
		f->pid = pid;
		if (source)
			snprintf(f->source, sizeof(f->source), "%s", source);
	}
	if (b->probing)
		return;
	bridge_count(&b->n_foreign);
	if (b->foreign_episode)
		return;
	b->foreign_episode = true;
	bridge_log(
		b, 4,
		"another rmdd publishes on %s*: instance %016" PRIx64
		" on host %s, pid %d%s%s; controllers on this prefix see both daemons' state and "
		"drive both: stop one, or give one another lcm.channel_prefix (its messages are "
		"counted in health_t foreign_messages)",
		b->opts.prefix, (uint64_t)f->instance, f->host[0] ? f->host : "?", (int)f->pid,
		f->source[0] ? ", configuration " : "", f->source);
}

/* An episode ends when nothing foreign came for this long (ten health_t periods). */
#define FOREIGN_QUIET_NS (1000 * RMD_NS_PER_MS)

static void foreign_expire(struct rmd_bridge *b, int64_t now)
{
	if (!b->foreign_episode || now - b->foreign_ns < FOREIGN_QUIET_NS)
		return;
	b->foreign_episode = false;
	bridge_log(b, 5,
		   "the other rmdd on %s* (instance %016" PRIx64 ", host %s, pid %d) went quiet",
		   b->opts.prefix, (uint64_t)b->foreign.instance, b->foreign.host,
		   (int)b->foreign.pid);
}

/*
 * A message on the prefix's STATE (probing only), HEALTH or CONFIG: ours
 * (LCM loops them back unless the link's filter drops them) or another
 * daemon's.
 * health_t at ~10 Hz and config_t on request: decoding them is cheap.
 */
static void on_foreign(struct rmd_bridge *b, const char *channel, const void *data, uint32_t size)
{
	if (!strcmp(channel, b->ch_health)) {
		rmd_health_t h;

		if (rmd_health_t_decode(data, 0, (int)size, &h) < 0)
			return;
		if (h.instance != b->opts.instance)
			note_foreign(b, h.instance, h.host, h.pid, NULL);
		rmd_health_t_decode_cleanup(&h);
	} else if (!strcmp(channel, b->ch_config)) {
		rmd_config_t c;

		if (rmd_config_t_decode(data, 0, (int)size, &c) < 0)
			return;
		if (c.instance != b->opts.instance)
			note_foreign(b, c.instance, c.host, c.pid, c.source);
		rmd_config_t_decode_cleanup(&c);
	} else if (b->probing && !strcmp(channel, b->ch_state)) {
		note_foreign(b, 0, NULL, 0, NULL);
	}
}

/* ---- the thread --------------------------------------------------------- */

void rmd_bridge_handle(struct rmd_bridge *b, const struct rmd_lcm_msg *m)
{
	if (!strcmp(m->channel, b->ch_command)) {
		bridge_admit_command(b, m); /* one too long to keep as well: it is refused */
		return;
	}
	if (!strcmp(m->channel, RMD_CHANNEL_ROBOT_STOP)) {
		bridge_robot_stop_in(b, m); /* any message stops, even one too long */
		return;
	}
	if (!m->data) /* too long to keep, and not a command: dropped */
		return;
	if (!strcmp(m->channel, RMD_CHANNEL_ROBOT_HEARTBEAT))
		bridge_robot_heartbeat_in(b, m);
	else if (!strcmp(m->channel, RMD_CHANNEL_ROBOT_CONFIG))
		bridge_robot_config_in(b, m);
	else if (!strcmp(m->channel, b->ch_config_req))
		on_config_request(b);
	else if (!strcmp(m->channel, b->ch_home))
		bridge_admit_home(b, m);
	else
		on_foreign(b, m->channel, m->data, m->size);
}

/*
 * Take what the link has, looking at the snapshots after each datagram or
 * message; true when it found nothing more.
 */
static bool drain_link(struct rmd_bridge *b)
{
	for (int n = 0; n < DRAIN_MAX; n++) {
		struct rmd_lcm_msg m;
		int r = rmd_lcm_link_receive(b->link, &m);

		if (r == -EAGAIN)
			return true;
		if (r == -EINTR)
			return false;
		if (r == 1 || r == -EMSGSIZE) {
			rmd_bridge_handle(b, &m);
		} else if (r < 0) {
			if (bridge_counted(&b->n_lcm_errors) == 0)
				bridge_log(b, 4,
					   "LCM receive failed (%s); further failures are counted",
					   strerror(-r));
			bridge_count(&b->n_lcm_errors);
			return false;
		}
		bridge_publish_state(b);
	}
	return false;
}

/*
 * Handle what has queued, and look at the snapshots after each message
 * (an atomic load when there is none): a flood of commands never holds
 * back the state.  Messages are judged by when they arrived
 * (arrival_ns()): the offset of CLOCK_REALTIME, on which receive stamps
 * come, is measured here, and a drain that finds the queue empty makes
 * its start b->rx_seen_ns, up to when every message has been looked at
 * (a drain cut short by DRAIN_MAX or an error leaves it).  Bridge thread.
 */
static void drain(struct rmd_bridge *b)
{
	int64_t start, off = rmd_realtime_offset_ns(&start);

	/*
	 * A clock step since the last drain: each stamp of this one is right
	 * with one of the two offsets.  The smaller makes it the later: a step
	 * never makes a controller look silent (the bounds hold either way).
	 */
	b->rx_off_ns = off < b->rx_off_last_ns ? off : b->rx_off_last_ns;
	b->rx_off_last_ns = off;
	if (drain_link(b))
		b->rx_seen_ns = start;
}

/*
 * How long the bridge may sleep: until the health timer or a pending
 * config_t is due; a state_t is due when the loop's notify_fd says so, and
 * only without one does the bridge look every poll_ns.
 */
static int64_t sleep_ns(const struct rmd_bridge *b, int64_t now, bool notified)
{
	int64_t due = b->next_health_ns;

	if (b->config_wanted && b->config_sent_ns + CONFIG_INTERVAL_NS < due)
		due = b->config_sent_ns + CONFIG_INTERVAL_NS;
	if (b->robot && b->next_hb_ns < due)
		due = b->next_hb_ns;
	if (!notified && b->state_listeners && b->opts.snapshots && now + b->opts.poll_ns < due)
		due = now + b->opts.poll_ns;
	return due > now ? due - now : 0;
}

/* What woke the bridge: epoll_event.data.u32. */
enum { WAKE_STOP, WAKE_RX, WAKE_SNAPSHOT, WAKE_TIMER };

/*
 * The bridge's one wait, set up once (rmd_bridge_new): an epoll set of
 * rmd_bridge_stop()'s eventfd, the link's descriptor (rmd/lcm_link.h),
 * the loop's notify_fd and a timerfd for the health
 * timer and a pending config_t.  The registrations persist, and notify_fd
 * is edge-triggered and never read: a snapshot costs one epoll_wait, not a
 * poll set built and torn down, a timer armed and cancelled and a read.
 * 0 or -errno.
 */
static int wait_setup(struct rmd_bridge *b)
{
	struct {
		int fd;
		uint32_t events, what;
	} w[] = {
		{ b->stop_fd, EPOLLIN, WAKE_STOP },
		{ rmd_lcm_link_fd(b->link), EPOLLIN, WAKE_RX },
		{ -1, EPOLLIN, WAKE_TIMER },
		/* no state_t to publish: the loop's pokes need not wake us */
		{ b->state_listeners ? b->opts.notify_fd : -1, EPOLLIN | EPOLLET, WAKE_SNAPSHOT },
	};

	b->ep_fd = epoll_create1(EPOLL_CLOEXEC);
	b->timer_fd = timerfd_create(CLOCK_MONOTONIC, TFD_CLOEXEC | TFD_NONBLOCK);
	if (b->ep_fd < 0 || b->timer_fd < 0)
		return -errno;
	w[2].fd = b->timer_fd;
	for (unsigned k = 0; k < sizeof(w) / sizeof(w[0]); k++) {
		struct epoll_event ev = { .events = w[k].events, .data.u32 = w[k].what };

		if (w[k].fd >= 0 && epoll_ctl(b->ep_fd, EPOLL_CTL_ADD, w[k].fd, &ev) < 0)
			return -errno;
	}
	return 0;
}

static void wait_close(struct rmd_bridge *b)
{
	if (b->ep_fd >= 0)
		close(b->ep_fd);
	if (b->timer_fd >= 0)
		close(b->timer_fd);
	b->ep_fd = b->timer_fd = -1;
}

/* The timer to CLOCK_MONOTONIC due_ns (already past: at once).  Bridge thread. */
static void arm_timer(struct rmd_bridge *b, int64_t due_ns)
{
	struct itimerspec its = { .it_value = { .tv_sec = due_ns / RMD_NS_PER_S,
						.tv_nsec = due_ns % RMD_NS_PER_S } };

	if (due_ns <= 0) /* 0 would disarm it */
		its.it_value.tv_nsec = 1;
	timerfd_settime(b->timer_fd, TFD_TIMER_ABSTIME, &its, NULL);
}

static void *bridge_main(void *arg)
{
	struct rmd_bridge *b = arg;
	int64_t now = rmd_now_ns(), armed_ns = -1;
	bool stop = false;

	pthread_setname_np(pthread_self(), "rmd-bridge");
	bridge_publish_config(b);
	b->config_sent_ns = now;
	b->next_health_ns = now + b->opts.health_period_ns;
	b->next_hb_ns = now;
	while (!stop) {
		struct epoll_event ev[4];
		bool readable = false;
		int64_t due;
		int n;

		now = rmd_now_ns();
		due = now + sleep_ns(b, now, b->opts.notify_fd >= 0);
		if (due != armed_ns) {
			arm_timer(b, due);
			armed_ns = due;
		}
		n = epoll_wait(b->ep_fd, ev, 4, -1);
		if (n < 0 && errno != EINTR) {
			bridge_log(b, 3, "LCM bridge: poll: %s; the bridge stops", strerror(errno));
			break;
		}
		for (int k = 0; k < n; k++) {
			uint64_t v;

			if (ev[k].data.u32 == WAKE_STOP)
				stop = true;
			readable |= ev[k].data.u32 == WAKE_RX;
			if (ev[k].data.u32 == WAKE_TIMER && read(b->timer_fd, &v, sizeof(v)) >= 0)
				armed_ns = -1; /* expired: armed again for what is due next */
		}
		if (stop)
			break;
		if (readable)
			drain(b);
		bridge_publish_state(b);
		now = rmd_now_ns();
		if (now >= b->next_health_ns) {
			drain(b); /* health_t's owner: judged on every message that came */
			foreign_expire(b, now); /* health_t names the other daemon while it lasts */
			bridge_publish_health(b, now);
			b->next_health_ns += b->opts.health_period_ns;
			if (b->next_health_ns <= now) /* late: skip, never catch up in a burst */
				b->next_health_ns = now + b->opts.health_period_ns;
		}
		if (b->robot && now >= b->next_hb_ns) {
			drain(b); /* the peers judged on every heartbeat that came */
			bridge_robot_tick(b, now);
			b->next_hb_ns += b->hb_period_ns;
			if (b->next_hb_ns <= now) /* late: skip, never catch up in a burst */
				b->next_hb_ns = now + b->hb_period_ns;
		}
		/* at most one config_t a CONFIG_INTERVAL_NS; a request in between waits for it */
		if (b->config_wanted && now - b->config_sent_ns >= CONFIG_INTERVAL_NS) {
			b->config_wanted = false;
			b->config_sent_ns = now;
			bridge_publish_config(b);
		}
	}
	bridge_robot_goodbye(b);
	return NULL;
}

/* ---- lifecycle ----------------------------------------------------------- */

static bool prefix_ok(const char *p)
{
	for (; *p; p++)
		if (!isalnum((unsigned char)*p) && !strchr("_-./", *p))
			return false;
	return true;
}

static bool latest_ok(const struct rmd_latest *l, size_t size, bool optional)
{
	return l ? l->size == size : optional;
}

static int check_opts(const struct rmd_bridge_opts *o, char *err, size_t errlen)
{
	if (!o->url[0] || strnlen(o->url, sizeof(o->url)) == sizeof(o->url))
		return snprintf(err, errlen, "LCM url empty or too long"), -EINVAL;
	if (strnlen(o->prefix, sizeof(o->prefix)) == sizeof(o->prefix) || !prefix_ok(o->prefix))
		return snprintf(err, errlen,
				"LCM channel prefix \"%.*s\": up to %d of A-Z a-z 0-9 _ - . /",
				(int)sizeof(o->prefix), o->prefix, RMD_BRIDGE_PREFIX_LEN - 1),
		       -EINVAL;
	if (o->nmotors < 1 || o->nmotors > RMD_MAX_MOTORS)
		return snprintf(err, errlen, "%u motors (1..%d)", o->nmotors, RMD_MAX_MOTORS),
		       -EINVAL;
	if (o->nbuses > RMD_MAX_BUSES)
		return snprintf(err, errlen, "%u buses (0..%d)", o->nbuses, RMD_MAX_BUSES), -EINVAL;
	if (!latest_ok(o->commands, sizeof(struct rmd_command), false) ||
	    !latest_ok(o->snapshots, sizeof(struct rmd_snapshot), true) ||
	    !latest_ok(o->health, sizeof(struct rmd_health), true))
		return snprintf(err, errlen, "hand-over buffers missing or of the wrong size"),
		       -EINVAL;
	if (o->stale_ms < 0 || o->command_timeout_ms < 0 || o->health_period_ns <= 0 ||
	    o->poll_ns <= 0)
		return snprintf(err, errlen,
				"stale_ms or command_timeout_ms < 0, or a period <= 0"),
		       -EINVAL;
	if (o->robot.instance[0] &&
	    (o->robot.n_peers > RMD_CONFIG_MAX_PEERS || o->robot.heartbeat_ms == 0 ||
	     o->robot.peer_timeout_ms == 0 ||
	     strnlen(o->robot.instance, RMD_CONFIG_INSTANCE_LEN) == RMD_CONFIG_INSTANCE_LEN))
		return snprintf(err, errlen,
				"robot: more than %d peers, a period of 0 or an unterminated name",
				RMD_CONFIG_MAX_PEERS),
		       -EINVAL;
	for (unsigned i = 0; o->robot.instance[0] && i < o->robot.n_peers; i++)
		if (!strcmp(o->robot.peers[i], o->robot.instance))
			return snprintf(err, errlen, "robot: peer %u is this daemon itself (%s)", i,
					o->robot.instance),
			       -EINVAL;
	if (o->rt_priority > 98)
		return snprintf(err, errlen, "rt_priority %u (0..98)", o->rt_priority), -EINVAL;
	for (unsigned i = 0; i < o->nbuses; i++)
		if (strnlen(o->bus[i].name, RMD_BRIDGE_NAME_LEN) == RMD_BRIDGE_NAME_LEN ||
		    strnlen(o->bus[i].kind, sizeof(o->bus[i].kind)) == sizeof(o->bus[i].kind))
			return snprintf(err, errlen, "bus %u: name or kind unterminated", i),
			       -EINVAL;
	for (unsigned i = 0; i < o->nmotors; i++) {
		const struct rmd_motor_info *m = &o->motor[i];

		if (strnlen(m->name, RMD_BRIDGE_NAME_LEN) == RMD_BRIDGE_NAME_LEN ||
		    strnlen(m->protocol, sizeof(m->protocol)) == sizeof(m->protocol))
			return snprintf(err, errlen, "motor %u: name or protocol unterminated", i),
			       -EINVAL;
		if (!m->modes || m->modes & ~RMD_BRIDGE_MODES_ALL)
			return snprintf(err, errlen, "motor %u (%s): modes 0x%x", i, m->name,
					m->modes),
			       -EINVAL;
		/* Written so that NaN fails each comparison. */
		if (!(m->pos_min_rad <= m->pos_max_rad) || !(m->vel_max_rad_s >= 0) ||
		    !(m->torque_max_nm >= 0) || !(m->kp_min <= m->kp_max) ||
		    !(m->kd_min <= m->kd_max))
			return snprintf(err, errlen,
					"motor %u (%s): limits: position min > max, a negative "
					"maximum, a gain range min > max, or NaN",
					i, m->name),
			       -EINVAL;
	}
	return 0;
}

/* ---- threads -------------------------------------------------------------- */

/*
 * The bridge thread, and LCM's receive threads with it (the link's: not on
 * udpm), to SCHED_FIFO rt_priority.  Refused: all stay at normal
 * priority, and rt_error says why.
 */
static void raise_threads(struct rmd_bridge *b)
{
	struct sched_param sp = { .sched_priority = (int)b->opts.rt_priority };
	int r;

	b->rt_granted = 0; /* a restart starts over */
	b->rt_error = 0;
	if (!b->opts.rt_priority)
		return;
	r = pthread_setschedparam(b->thread, SCHED_FIFO, &sp);
	if (r) {
		b->rt_error = -r;
		return;
	}
	b->rt_granted = b->opts.rt_priority;
	r = rmd_lcm_link_raise(b->link, b->opts.rt_priority);
	if (r < 0)
		b->rt_error = r;
}

/*
 * Once, at start: the link's protections that are not in place, and why
 * (rmd/lcm_link.h).  memq:// has no socket and no other sender: nothing
 * to say.
 */
static void log_link(struct rmd_bridge *b)
{
	struct rmd_lcm_link_info in;

	rmd_lcm_link_info(b->link, &in);
	if (!in.udpm) {
		if (b->state_listeners)
			bridge_log(
				b, 5,
				"LCM %s: not udpm://: commands come through LCM's own receive path "
				"(handled in the bridge thread; of LCM's threads %u found, %u at "
				"SCHED_FIFO), stamped by LCM, and our own messages come back to us",
				b->opts.url, in.lcm_threads, in.lcm_threads_rt);
		return;
	}
	if (!in.filter)
		bridge_log(
			b, 4,
			"LCM %s: the kernel refused the filter that drops our own datagrams (%s): "
			"the bridge reads back and drops each message it sends",
			b->opts.url, strerror(-in.filter_error));
	if (!in.stamps)
		bridge_log(b, 4,
			   "LCM %s: no kernel receive stamps (%s): a command's arrival is when the "
			   "bridge reads it",
			   b->opts.url, strerror(-in.stamps_error));
}

/* ---- lifecycle, continued ------------------------------------------------- */

int rmd_bridge_new(struct rmd_bridge **out, const struct rmd_bridge_opts *opts, char *err,
		   size_t errlen)
{
	struct rmd_lcm_link_opts lo = { .url = opts->url,
					.prefix = opts->prefix,
					/* alone, the robot's channels are not even read */
					.prefix2 = opts->robot.instance[0] ?
							   RMD_CHANNEL_ROBOT_PREFIX :
							   NULL,
					.recv_buf_size = RMD_BRIDGE_UDPM_RCVBUF,
					.queue = COMMAND_QUEUE };
	struct rmd_bridge *b;
	int r;

	*out = NULL;
	r = check_opts(opts, err, errlen);
	if (r < 0)
		return r;
	b = calloc(1, sizeof(*b));
	if (b)
		b->buf = calloc(1, sizeof(*b->buf));
	if (!b || !b->buf) {
		free(b);
		snprintf(err, errlen, "out of memory");
		return -ENOMEM;
	}
	b->stop_fd = -1;
	b->ep_fd = -1;
	b->timer_fd = -1;
	b->config_mu = (pthread_mutex_t)PTHREAD_MUTEX_INITIALIZER;
	b->rx_off_last_ns = rmd_realtime_offset_ns(&b->rx_seen_ns);
	b->rx_at_ns = b->rx_seen_ns; /* nothing can have come before */
	b->opts = *opts;
	if (b->opts.state_every == 0)
		b->opts.state_every = 1;
	snprintf(b->ch_command, sizeof(b->ch_command), "%s" RMD_CHANNEL_COMMAND, opts->prefix);
	snprintf(b->ch_state, sizeof(b->ch_state), "%s" RMD_CHANNEL_STATE, opts->prefix);
	snprintf(b->ch_health, sizeof(b->ch_health), "%s" RMD_CHANNEL_HEALTH, opts->prefix);
	snprintf(b->ch_config, sizeof(b->ch_config), "%s" RMD_CHANNEL_CONFIG, opts->prefix);
	snprintf(b->ch_config_req, sizeof(b->ch_config_req), "%s" RMD_CHANNEL_CONFIG_REQUEST,
		 opts->prefix);
	snprintf(b->ch_home, sizeof(b->ch_home), "%s" RMD_CHANNEL_HOME, opts->prefix);
	bridge_robot_init(b);

	b->stop_fd = eventfd(0, EFD_CLOEXEC | EFD_NONBLOCK);
	if (b->stop_fd < 0) {
		r = -errno;
		snprintf(err, errlen, "eventfd: %s", strerror(-r));
		goto err_free_bridge;
	}
	b->state_listeners = strncmp(opts->url, "memq://", 7) != 0;
	r = rmd_lcm_link_new(&b->link, &lo, err, errlen);
	if (r < 0)
		goto err_free_bridge;
	r = wait_setup(b);
	if (r < 0) {
		snprintf(err, errlen, "epoll, timerfd: %s", strerror(-r));
		goto err_free_bridge;
	}
	*out = b;
	return 0;
err_free_bridge:
	rmd_bridge_free(b);
	return r;
}

int rmd_bridge_probe(struct rmd_bridge *b, int64_t wait_ns, struct rmd_bridge_peer *peer)
{
	rmd_config_request_t req = { .utime = rmd_now_ns() / 1000 };
	int64_t end = rmd_now_ns() + wait_ns;
	struct pollfd pfd = { .fd = rmd_lcm_link_fd(b->link), .events = POLLIN };
	int n;

	memset(peer, 0, sizeof(*peer));
	if (!b->state_listeners || b->running)
		return 0;
	memset(&b->foreign, 0, sizeof(b->foreign));
	b->probing = true;
	/* a daemon answers with config_t (within CONFIG_INTERVAL_NS): it names its source */
	n = rmd_config_request_t_encode(b->buf->enc, 0, ENC_MAX, &req);
	if (n < 0 || rmd_lcm_link_publish(b->link, b->ch_config_req, b->buf->enc, (size_t)n) < 0) {
		b->probing = false;
		return -EIO;
	}
	for (;;) {
		int64_t now = rmd_now_ns();
		int ms;

		/* named by its config_t: nothing more to learn */
		if (now >= end || b->foreign.source[0])
			break;
		ms = (int)((end - now + RMD_NS_PER_MS - 1) / RMD_NS_PER_MS);
		if (poll(&pfd, 1, ms) < 0 && errno != EINTR) {
			b->probing = false;
			return -errno;
		}
		drain(b);
	}
	b->probing = false;
	*peer = b->foreign;
	/* the running bridge tells its own episode (it logs once) */
	memset(&b->foreign, 0, sizeof(b->foreign));
	return (int)(peer->messages > INT_MAX ? INT_MAX : peer->messages);
}

int rmd_bridge_start(struct rmd_bridge *b)
{
	int r;

	if (b->running)
		return -EALREADY;
	r = rmd_thread_start_normal(&b->thread, bridge_main, b);
	if (r)
		return r;
	b->running = true;
	raise_threads(b);
	log_link(b);
	return 0;
}

void rmd_bridge_stop(struct rmd_bridge *b)
{
	uint64_t one = 1;

	if (!b->running)
		return;
	if (write(b->stop_fd, &one, sizeof(one)) < 0) {
		/* an eventfd write fails only on overflow: already signalled */
	}
	pthread_join(b->thread, NULL);
	b->running = false;
	if (read(b->stop_fd, &one, sizeof(one)) < 0) {
		/* nothing to clear */
	}
}

int rmd_bridge_config_copy(struct rmd_bridge *b, void *out, size_t len)
{
	int n = 0;

	pthread_mutex_lock(&b->config_mu);
	if (b->buf->config_len > 0 && (size_t)b->buf->config_len <= len) {
		n = b->buf->config_len;
		memcpy(out, b->buf->config_enc, (size_t)n);
	}
	pthread_mutex_unlock(&b->config_mu);
	return n;
}

void rmd_bridge_free(struct rmd_bridge *b)
{
	if (!b)
		return;
	rmd_bridge_stop(b);
	wait_close(b);
	rmd_lcm_link_free(b->link);
	if (b->stop_fd >= 0)
		close(b->stop_fd);
	free(b->buf);
	free(b);
}

const struct rmd_bridge_opts *rmd_bridge_get_opts(const struct rmd_bridge *b)
{
	return &b->opts;
}

void rmd_bridge_get_stats(struct rmd_bridge *b, struct rmd_bridge_stats *st)
{
	struct rmd_lcm_link_info in = { 0 };

	if (b->link)
		rmd_lcm_link_info(b->link, &in);
	memset(st, 0, sizeof(*st));
	st->accepted = bridge_counted(&b->n_accepted);
	for (int k = 0; k < RMD_REJ_KINDS; k++) {
		st->rejected_by_kind[k] = bridge_counted(&b->n_rejected[k]);
		st->rejected += st->rejected_by_kind[k];
	}
	st->clamped = bridge_counted(&b->n_clamped);
	st->states_published = bridge_counted(&b->n_states);
	st->health_published = bridge_counted(&b->n_health);
	st->configs_published = bridge_counted(&b->n_configs);
	st->publish_errors = bridge_counted(&b->n_publish_errors);
	st->foreign = bridge_counted(&b->n_foreign);
	st->lcm_errors = bridge_counted(&b->n_lcm_errors);
	st->robot_stops = bridge_counted(&b->n_robot_stops);
	st->takeovers = bridge_counted(&b->n_takeovers);
	st->owned = atomic_load_explicit(&b->pub_owned, memory_order_relaxed);
	st->owner = atomic_load_explicit(&b->pub_owner, memory_order_relaxed);
	st->intruder = atomic_load_explicit(&b->pub_intruder, memory_order_relaxed);
	st->rt_priority = b->rt_granted;
	st->rt_error = b->rt_error;
	st->lcm_threads = in.lcm_threads;
	st->lcm_threads_rt = in.lcm_threads_rt;
	st->own_dropped = in.filter;
	st->datagrams = in.datagrams;
}
