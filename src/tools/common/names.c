// SPDX-License-Identifier: MIT
/*
 * State names (names.h).  rt-safe.
 */
#include "rmd/state.h"
#include "names.h"

const char *tool_lifecycle_name(unsigned lc)
{
	static const char *const names[RMD_LC_COUNT] = {
		[RMD_LC_PROBE] = "probe",	[RMD_LC_READY] = "ready",
		[RMD_LC_ENABLED] = "enabled",	[RMD_LC_FAULT] = "fault",
		[RMD_LC_LOST] = "lost",		[RMD_LC_SAFE] = "safe",
		[RMD_LC_STOPPING] = "stopping",
	};

	return lc < RMD_LC_COUNT ? names[lc] : "?";
}

const char *tool_watchdog_name(unsigned wd)
{
	static const char *const names[] = {
		[RMD_WD_IDLE] = "idle",
		[RMD_WD_OK] = "ok",
		[RMD_WD_TRIPPED] = "tripped",
	};

	return wd < sizeof(names) / sizeof(names[0]) ? names[wd] : "?";
}

const char *tool_comm_loss_name(unsigned cl)
{
	static const char *const names[RMD_CL_COUNT] = {
		[RMD_CL_PENDING] = "pending",	      [RMD_CL_ARMED] = "armed",
		[RMD_CL_ARMED_ZEROS] = "armed_zeros", [RMD_CL_NO_ANSWER] = "no_answer",
		[RMD_CL_DIFFERS] = "differs",	      [RMD_CL_OFF] = "off",
		[RMD_CL_UNSUPPORTED] = "unsupported",
	};

	return cl < RMD_CL_COUNT ? names[cl] : "?";
}
