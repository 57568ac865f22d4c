/* SPDX-License-Identifier: MIT */
/*
 * Names of the states rmdd reports (include/rmd/state.h, the values of
 * rmd.state_t LC_*, rmd.health_t WD_* and CL_*), one table each, for the
 * programs' messages and tables: rmdd's log and `rmdctl top`.  Unknown
 * values read "?".  rt-safe (constant strings).
 */
#ifndef RMD_TOOL_NAMES_H
#define RMD_TOOL_NAMES_H

/* "probe", "ready", "enabled", "fault", "lost", "safe". */
const char *tool_lifecycle_name(unsigned lc);

/* "idle", "ok", "tripped". */
const char *tool_watchdog_name(unsigned wd);

/* "pending", "armed", "armed_zeros", "no_answer", "differs", "off", "unsupported". */
const char *tool_comm_loss_name(unsigned cl);

#endif /* RMD_TOOL_NAMES_H */
