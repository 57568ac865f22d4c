// SPDX-License-Identifier: MIT
/*
 * Identifying a motor's firmware (rmd/proc_ident.h).
 *
 * Execution context: pure, rt-safe.
 */
#include <string.h>

#include "rmd/proc_ident.h"

void rmd_ident_open(struct rmd_ident *id, const struct rmd_dialect *d)
{
	id->open = rmd_dialect_has(d, RMD_DIALECT_VERSION_B2);
}

unsigned rmd_ident_asks(const struct rmd_ident *id, bool mit_mode, uint8_t cmds[2])
{
	unsigned n = 0;

	if (!id->open)
		return 0;
	if (mit_mode)
		cmds[n++] =
			0xB5; /* V3 §2.32: the model, which with the date decides its MIT scaling */
	cmds[n++] = 0xB2;     /* V3 §2.29: the firmware date */
	return n;
}

enum rmd_ident_outcome rmd_ident_answer(struct rmd_ident *id, const struct rmd_dialect *d,
					const struct rmd_motor_reply *r,
					const struct rmd_dialect **fw)
{
	*fw = NULL;
	if (r->have & RMD_MOTOR_HAVE_MODEL)
		memcpy(id->model, r->model, sizeof(id->model));
	if (!(r->have & RMD_MOTOR_HAVE_VERSION))
		return RMD_IDENT_WAIT;
	id->version = r->version_date;
	id->open = false;
	return rmd_dialect_other_firmware(d, r->version_date, fw) ? RMD_IDENT_OTHER :
								    RMD_IDENT_SAME;
}

bool rmd_ident_mit_warn_once(struct rmd_ident *id)
{
	if (id->mit_warned)
		return false;
	id->mit_warned = true;
	return true;
}
