// SPDX-License-Identifier: MIT
/*
 * rmdctl: command-line tool for RMD motors (the tools layer of docs/design.md).
 *
 *   decode.c    candump text -> decoded quantities
 *   encode.c    one command -> a frame in cansend syntax
 *   read.c      scan, info, status, monitor
 *   rtt.c       round trips and the loop rate a bus supports
 *   settings.c  set-id, set-zero, set-timeout, accel, pid
 *   dump.c      dump, restore: every readable setting as YAML, and back
 *   motion.c    brake, stop, off, reset, move
 *   characterize.c  one motor recorded as a personality file and a log
 *   top.c       a running rmdd, over LCM (no bus): fills a top_view
 *               (top_view.c) that its table, its JSON and top_screen.c
 *               (the ncurses screen on a terminal) only read
 *   bench.c     what the device commands share: command line, bus, --trace,
 *               confirmation, transactions; output.c prints their results
 *   parse.c     what every command's command line shares: decode's and
 *               encode's options, numbers, usage hints, protocol phrases
 *
 * Commands are the rows of `cmds` below: name, one-line summary, arguments,
 * options, help and run.  decode, encode and top parse their own command
 * line, each from its own option table.
 * Exit statuses: 0 ok, 1 data or device errors, 2 usage.  Non-rt.
 */
#include <errno.h>
#include <getopt.h>
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "rmdctl.h"

/* A device command: name, summary, args, min and max arg count, options, help, run. */
#define DEV(n, s, a, lo, hi, o, h, r)                                                          \
	{                                                                                      \
		.name = n, .summary = s, .args = a, .min_args = lo, .max_args = hi, .opts = o, \
		.help = h, .run = r                                                            \
	}

static const struct rmdctl_cmd cmds[] = {
	{ .name = "decode",
	  .summary = "print candump output as decoded quantities (text or JSON)",
	  .args = "[FILE]",
	  .main = rmdctl_decode_run,
	  .usage = rmdctl_decode_usage },
	{ .name = "encode",
	  .summary = "print one command as a frame in cansend syntax",
	  .args = "COMMAND [ARGS...]",
	  .main = rmdctl_encode_run,
	  .usage = rmdctl_encode_usage },
	{ .name = "top",
	  .summary = "live view of a running rmdd over LCM (motors, buses, loop)",
	  .main = rmdctl_top_run,
	  .usage = rmdctl_top_usage },
	DEV("scan", "list the motors that answer on a bus", "[IDS]", 0, 1, O_JSON,
	    "Probes ids 1..32 (or IDS, e.g. 1-8) with 0x9A status, pipelined, then asks\n"
	    "the motors that answered for their model (0xB5) and firmware date (0xB2;\n"
	    "V3 only).  Lists id, model, firmware date, protocol, temperature, voltage,\n"
	    "brake and errors.  Exit 1 when no motor answers.\n",
	    rmdctl_run_scan),
	DEV("info", "model, firmware, runtime, acceleration, gains, mode of a motor", "ID", 1, 1,
	    O_JSON,
	    "Model (0xB5), firmware date (0xB2), runtime (0xB1), acceleration (0x42), PI\n"
	    "gains (0x30; V2 0x30..0x35) and run mode (0x70).  The comm-loss timeout\n"
	    "(0xB3) cannot be read back: the protocol only writes it.\n",
	    rmdctl_run_info),
	DEV("status", "temperature, voltage, errors, angle, speed, current of a motor", "ID", 1, 1,
	    O_JSON,
	    "Temperature, voltage, error flags by name and brake (0x9A), multi-turn\n"
	    "angle (0x92), speed and current (0x9C).\n",
	    rmdctl_run_status),
	DEV("monitor", "live status table of the motors on a bus", "[IDS]", 0, 1,
	    O_JSON | O_ONCE | O_INTERVAL,
	    "A live table of the status of every motor (IDS, or those that answer a\n"
	    "probe of 1..32), refreshed every 200 ms until Ctrl-C; on a terminal the\n"
	    "screen is cleared each time.  --once prints one table and exits (1 if a\n"
	    "motor did not answer).  It talks on the bus itself: on a bus a running\n"
	    "rmdd drives it refuses (--force talks anyway); `rmdctl top` shows rmdd's\n"
	    "view instead.\n",
	    rmdctl_run_monitor),
	DEV("rtt", "round trip of each motor and the loop rate the bus supports", "[IDS]", 0, 1,
	    O_JSON | O_COUNT,
	    "Measures each motor's round trip (IDS, or those that answer a probe of\n"
	    "1..32): --count requests of 0x9A status, 0x9C status 2 and 0x92 angle,\n"
	    "one outstanding per motor (on RS485 one on the line), first tries only;\n"
	    "prints min, median, p99 and max per motor and command.  Then the loop\n"
	    "rate the bus supports, one request per motor per cycle, by the planner's\n"
	    "arithmetic with the measured p99 as the turnaround: CAN carries the\n"
	    "requests at once and the slowest reply must arrive before the next\n"
	    "cycle; RS485 sends them in series, each paying its round trip (and it\n"
	    "prints the turnaround_us for rmdd.yaml).  --timeout defaults to 100 ms\n"
	    "here, and is RS485's own reply timeout too: on a line, name the motors\n"
	    "(IDS), as each silent id of a probe holds the line that long per try.\n"
	    "--count is at most 10000.  Exit 1 when nothing answers.\n",
	    rmdctl_run_rtt),
	DEV("dump", "every motor's readable settings as YAML (restore writes them back)", "[IDS]",
	    0, 1, 0,
	    "Writes the settings of every motor that answers (IDS, or a probe of 1..32)\n"
	    "as YAML on stdout: PID gains (0x30; V4: seven floats by index),\n"
	    "position-planning acceleration (0x42) and multi-turn zero offset (0x62);\n"
	    "model and firmware date as comments, and the protocol.  V3 and V4 cannot\n"
	    "read back the comm-loss time (0xB3), the CAN-ID filter and other 0x20\n"
	    "functions, the baud rate (0xB4) or the other three accelerations (0x43\n"
	    "index 1..3): they are not in the file.  V3 and V4 only.\n",
	    rmdctl_run_dump),
	DEV("restore", "write settings from a dump back, showing the diff (ROM)", "FILE", 1, 1,
	    O_YES | O_FORCE,
	    "Reads FILE (from `rmdctl dump`), reads the same settings of each motor in\n"
	    "it, prints what differs, asks once, and writes only that, to ROM: gains\n"
	    "(0x32), acceleration (0x43 index 0), zero offset (0x63: used after a reset\n"
	    "or power cycle).  A `comm_loss_ms: MS` added to a motor is written (0xB3)\n"
	    "every time, as it cannot be read back.  Without a terminal and --yes it\n"
	    "prints the diff and refuses (exit 2): a dry run.  A file of another\n"
	    "protocol than --protocol is refused (its gains do not translate); --force\n"
	    "writes all but the gains.  V3 and V4 only.\n",
	    rmdctl_run_restore),
	DEV("set-id", "renumber a motor (ROM)", "OLD NEW", 2, 2, O_YES | O_FORCE,
	    "Renumbers motor OLD to NEW (ROM) and checks that NEW answers and OLD no\n"
	    "longer does; refuses a NEW that a motor answers on.  V3 sends 0x79 on\n"
	    "0x300, which every motor on the bus with its CAN-ID filter off (0x20\n"
	    "index 2) obeys: with other motors answering, set-id refuses unless\n"
	    "--force.  V4 (--protocol v4) writes NEW with 0x20 index 5 to OLD alone\n"
	    "(its echo comes from OLD or, firmware 2025070202, NEW: either is taken\n"
	    "the first time, as each try writes flash), resets it (0x76), and waits up\n"
	    "to 3 s for the boot (1.12 s measured): NEW's runtime (0xB1) must have\n"
	    "restarted.  OLD's firmware date (0xB2) is asked first: a motor whose\n"
	    "date says another dialect's way (2025070202: 0x20 index 5, not 0x79) is\n"
	    "renumbered that way, said on stderr; so is one that answers 0x79 with a\n"
	    "0xB2 frame.  Asks for confirmation.\n",
	    rmdctl_run_set_id),
	DEV("characterize", "record one motor: a personality file and a candump log (ROM)", "ID", 1,
	    1, O_YES | O_COUNT | O_OUT | O_MOVE | O_SPEED | O_POWER,
	    "Runs a fixed exchange with motor ID and writes PREFIX.log (every frame as\n"
	    "a `candump -l` line, the bus's receive times) and PREFIX.personality (the\n"
	    "file `rmd-sim --personality` and the sim bus replay, docs/rmd-sim.md):\n"
	    "model (0xB5), firmware date (0xB2) and the dialect it says; every read\n"
	    "command of that dialect --count times, one outstanding: the turnaround\n"
	    "distribution of each (round trip less the frames on the wire), and the\n"
	    "ones never answered; 0x79 read on its own id (answered by a 0xB2 frame:\n"
	    "firmware 2025070202); 0xB3 written 1000 ms (ROM) and its echo checked,\n"
	    "then 0 (off); a reset (0x76) and the time to its first answer.  Nothing\n"
	    "moves unless --move DEG (at most 10 deg, and back, at --speed, default\n"
	    "and at most 10 dps; stopped with 0x81 on anything odd).  --power-cycle\n"
	    "asks for a power cycle (a terminal) and notes the angle before and\n"
	    "after.  The MIT ranges written are the table's for the date and model,\n"
	    "not measured.  CAN and sim buses.  Takes about --count x the commands x\n"
	    "a round trip, plus the boot.  Asks for confirmation.\n",
	    rmdctl_run_characterize),
	DEV("set-zero", "make the current position the zero (ROM)", "ID", 1, 1, O_YES,
	    "Makes the current position the zero (0x64, ROM).  It applies after a reset\n"
	    "(`rmdctl reset ID`, 0x76) or a power cycle.  Asks for confirmation.\n",
	    rmdctl_run_set_zero),
	DEV("multiturn-save", "keep the multi-turn count at power off (ROM)", "ID on|off", 2, 2,
	    O_YES,
	    "Turns on (or off) the motor's saving of its multi-turn count at power off\n"
	    "(0x20 index 4, V3.5 and later, V4; ROM).  It applies after a restart\n"
	    "(`rmdctl reset ID`).  Without it a motor comes back within one turn of its\n"
	    "encoder after a power cycle.  No command reads it back: say\n"
	    "multi_turn_saved in rmdd.yaml.  Asks for confirmation.\n",
	    rmdctl_run_multiturn_save),
	DEV("angle-limit", "set a position-mode angle limit (ROM; V4)", "ID positive|negative DEG",
	    3, 3, O_YES,
	    "Sets the most positive or negative output angle the motor's position modes\n"
	    "go to (V4.2 0x20 index 6/7, ROM, at once).  The manual gives no unit: DEG\n"
	    "is written in 0.01 deg, as its position commands take (unverified).  No\n"
	    "command reads it back.  Asks for confirmation.\n",
	    rmdctl_run_angle_limit),
	DEV("set-timeout", "set the comm-loss protection time (ROM)", "ID MS", 2, 2, O_YES,
	    "Sets the comm-loss protection time (0xB3, ROM; 0 turns it off) and checks\n"
	    "the echo.  V3 only.  Asks for confirmation.\n",
	    rmdctl_run_set_timeout),
	DEV("accel", "read or write acceleration", "ID [INDEX DPS2]", 1, 3,
	    O_JSON | O_YES | O_FORCE,
	    "Reads the acceleration (0x42), or writes one (0x43): V3 by INDEX, 0\n"
	    "position-accel, 1 position-decel, 2 speed-accel, 3 speed-decel (RAM and\n"
	    "ROM: asks for confirmation), DPS2 100..60000 dps/s; V2 `accel ID DPS2`\n"
	    "(RAM).\n",
	    rmdctl_run_accel),
	DEV("pid", "read or write PID gains",
	    "ID [CURR_KP CURR_KI SPD_KP SPD_KI POS_KP POS_KI [POS_KD]]", 1, 8,
	    O_JSON | O_YES | O_ROM,
	    "Reads the PI gains of the current, speed and position loops (0x30), or\n"
	    "writes all six: V3 integers 0..255 (units of 1/256 of a model-dependent\n"
	    "maximum) with 0x31 (RAM) or, with --rom, 0x32 (ROM: asks for\n"
	    "confirmation); V2 Q24 reals with 0x36..0x3B / 0x3C..0x41; V4 (V4.2 §2.1)\n"
	    "reals, one 0x30/0x31/0x32 frame by index each, and the position KD too.\n",
	    rmdctl_run_pid),
	DEV("brake", "lock or release the brake", "ID on|off", 2, 2, O_YES,
	    "on (or lock): brake locked (0x78).  off (or release): brake released\n"
	    "(0x77); the load may move the shaft, so it asks for confirmation.\n",
	    rmdctl_run_brake),
	DEV("stop", "stop and hold position; --robot: stop the whole robot", "ID", 1, 1, 0,
	    "Stops the motor and holds its position (0x81).\n"
	    "`rmdctl stop --robot` stops every rmdd of the robot instead, over LCM\n"
	    "(`rmdctl stop --robot --help`; docs/robot.md).\n",
	    rmdctl_run_stop),
	DEV("off", "turn the output off", "ID", 1, 1, 0,
	    "Turns the output off and clears the running mode (0x80); the shaft is then\n"
	    "free (a brake, if any, holds it only when locked).\n",
	    rmdctl_run_off),
	DEV("reset", "reset a motor and wait for it", "ID", 1, 1, 0,
	    "Resets the motor (0x76) and waits until it answers again.  Multi-turn\n"
	    "position is RAM: it restarts within +-180 deg.  ROM writes (set-zero)\n"
	    "take effect.\n",
	    rmdctl_run_reset),
	DEV("move", "small, slow absolute move, waiting for arrival", "ID DEG", 2, 2,
	    O_JSON | O_YES | O_SPEED | O_FORCE | O_NOWAIT,
	    "Moves to the absolute multi-turn angle DEG at --speed (default 30 dps) with\n"
	    "0xA4, releasing the brake first if it is locked, then polls the angle\n"
	    "(0x92) every 20 ms until the motor is within 0.2 deg of DEG and reports\n"
	    "the final angle (--no-wait: return at once).  Refuses speeds above 90 dps,\n"
	    "moves longer than 360 deg and motors reporting errors unless --force.\n"
	    "Ctrl-C, a stall or a timeout stops the motor (0x81).  Asks for\n"
	    "confirmation.\n",
	    rmdctl_run_move),
};
#define NCMDS (sizeof(cmds) / sizeof(cmds[0]))

/* rmdctl's own options, before any command. */
static const struct tool_opt main_opts[] = {
	{ .name = "help", .shortc = 'h', .help = "" },
	TOOL_OPT_VERSION(""),
	TOOL_OPT_COMPLETION,
};
#define NMAIN (sizeof(main_opts) / sizeof(main_opts[0]))

static void usage(FILE *f)
{
	fprintf(f, "usage: rmdctl COMMAND [ARGS...]\n"
		   "       rmdctl help [COMMAND]\n"
		   "       rmdctl --version\n"
		   "\n"
		   "Tool for MyActuator RMD servo motors (protocols V2, V3, V4 and MIT mode).\n"
		   "\n"
		   "commands:\n");
	for (size_t i = 0; i < NCMDS; i++)
		fprintf(f, "  %-12s %s\n", cmds[i].name, cmds[i].summary);
	fprintf(f, "\n"
		   "`rmdctl COMMAND --help` describes one command.\n"
		   "\n"
		   "exit status: 0 ok; 1 data or device errors (bad input lines, I/O, values\n"
		   "the codec refuses, a motor or bus that failed); 2 usage errors, and\n"
		   "refused confirmations or safety limits.\n");
}

static char log_name[32];

static const struct rmdctl_cmd *find_cmd(const char *name)
{
	for (size_t i = 0; i < NCMDS; i++)
		if (!strcmp(cmds[i].name, name))
			return &cmds[i];
	return NULL;
}

void rmdctl_usage_hint_name(const char *name)
{
	rmdctl_usage_hint(find_cmd(name));
}

static bool is_help(const char *s)
{
	return !strcmp(s, "-h") || !strcmp(s, "--help") || !strcmp(s, "help");
}

/* "unknown command "stauts" (did you mean status?)", the usage line and "see --help". */
static int unknown_command(const char *what, const char *name)
{
	struct tool_near near;

	tool_near_init(&near, name);
	for (size_t i = 0; i < NCMDS; i++)
		tool_near_try(&near, cmds[i].name);
	if (name[0] == '-')
		fprintf(stderr, "rmdctl: %s \"%s\" (options come after COMMAND)\n", what, name);
	else if (near.best)
		fprintf(stderr, "rmdctl: %s \"%s\" (did you mean %s?)\n", what, name, near.best);
	else
		fprintf(stderr, "rmdctl: %s \"%s\"\n", what, name);
	rmdctl_usage_hint(NULL);
	return RMDCTL_EXIT_USAGE;
}

/* `rmdctl --completion bash`: every command with its options, from the tables of --help. */
static void completion(void)
{
	struct tool_compl_cmd cc[NCMDS];

	for (size_t i = 0; i < NCMDS; i++) {
		cc[i] = (struct tool_compl_cmd){ .name = cmds[i].name };
		if (cmds[i].run) {
			cc[i].opts = rmdctl_dev_opts;
			cc[i].n = rmdctl_n_dev_opts;
			cc[i].flags = cmds[i].opts;
		} else if (!strcmp(cmds[i].name, "decode")) {
			cc[i].opts = rmdctl_decode_opts;
			cc[i].n = rmdctl_n_decode_opts;
			cc[i].files = true;
		} else if (!strcmp(cmds[i].name, "encode")) {
			cc[i].opts = rmdctl_encode_opts;
			cc[i].n = rmdctl_n_encode_opts;
		} else if (!strcmp(cmds[i].name, "top")) {
			cc[i].opts = rmdctl_top_opts;
			cc[i].n = rmdctl_n_top_opts;
		}
	}
	tool_completion_bash(stdout, "rmdctl", main_opts, NMAIN, cc, NCMDS);
}

int main(int argc, char **argv)
{
	const struct rmdctl_cmd *cmd;

	tool_log_init("rmdctl", TOOL_LOG_DEBUG, TOOL_LOG_NO_LEVEL);
	if (argc < 2) {
		fprintf(stderr, "rmdctl: missing COMMAND\n");
		rmdctl_usage_hint(NULL);
		return RMDCTL_EXIT_USAGE;
	}
	if (!strcmp(argv[1], "--version") || !strcmp(argv[1], "-V")) {
		tool_print_version("rmdctl");
		return RMDCTL_EXIT_OK;
	}
	if (!strcmp(argv[1], "--completion")) {
		if (!tool_completion_shell("rmdctl", argc == 3 ? argv[2] : NULL))
			return RMDCTL_EXIT_USAGE;
		completion();
		return RMDCTL_EXIT_OK;
	}
	if (is_help(argv[1])) {
		if (argc == 2) {
			usage(stdout);
			return RMDCTL_EXIT_OK;
		}
		cmd = find_cmd(argv[2]);
		if (!cmd || argc > 3)
			return unknown_command("no help for", argv[2]);
		if (cmd->usage)
			cmd->usage(stdout);
		else
			rmdctl_dev_usage(stdout, cmd);
		return RMDCTL_EXIT_OK;
	}
	cmd = find_cmd(argv[1]);
	if (!cmd)
		return unknown_command("unknown command", argv[1]);
	/* Messages read "rmdctl scan: ...". */
	snprintf(log_name, sizeof(log_name), "rmdctl %s", cmd->name);
	tool_log_init(log_name, TOOL_LOG_DEBUG, TOOL_LOG_NO_LEVEL);
	if (!strcmp(cmd->name, "stop") && rmdctl_is_robot_stop(argc - 1, argv + 1))
		return rmdctl_robot_stop_run(argc - 1, argv + 1);
	if (cmd->main)
		return cmd->main(argc - 1, argv + 1);
	return rmdctl_dev_run(cmd, argc - 1, argv + 1);
}
