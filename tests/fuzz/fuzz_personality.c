// SPDX-License-Identifier: MIT
/*
 * The personality file's parser (rmd_personality_parse(),
 * rmd/sim_personality.h): any bytes as the file.  It returns 0, -EINVAL or
 * -EFBIG with an error inside its buffer; what it accepts is written back
 * (rmd_personality_write()) and parses to the same record, and a motor of
 * that personality starts and answers, its turnaround draws inside the
 * record's quantiles.
 *
 * Input: the file's text.
 */
#include <errno.h>
#include <stddef.h>
#include <stdint.h>
#include <stdio.h>
#include <string.h>

#include "rmd/sim.h"
#include "rmd/sim_personality.h"

#include "fuzz.h"

int LLVMFuzzerTestOneInput(const uint8_t *data, size_t size)
{
	static struct rmd_personality rec, back;
	static struct rmd_sim_motor m;
	static char text[RMD_PERSONALITY_FILE_MAX * 2];
	static char err[512];
	struct rmd_sim_motor_params p;
	struct rmd_frame req = { .can_id = 0x141, .len = 8 }, out[8];
	FILE *f;
	int r;

	err[sizeof(err) - 1] = 'x';
	r = rmd_personality_parse((const char *)data, size, "f", &rec, err, sizeof(err) - 1);
	FUZZ_CHECK(r == 0 || r == -EINVAL || r == -EFBIG);
	FUZZ_CHECK(err[sizeof(err) - 1] == 'x');
	if (r < 0) {
		FUZZ_CHECK(memchr(err, 0, sizeof(err) - 1) && !strncmp(err, "f:", 2));
		return 0;
	}
	f = fmemopen(text, sizeof(text), "w");
	FUZZ_CHECK(f != NULL);
	FUZZ_CHECK(rmd_personality_write(f, &rec, "fuzz") == 0);
	fclose(f);
	r = rmd_personality_parse(text, strlen(text), "f", &back, err, sizeof(err) - 1);
	FUZZ_CHECK(r == 0);
	/* the name a nameless file took from its path comes back as a `name` line */
	FUZZ_CHECK(!memcmp(&back, &rec, sizeof(rec)));

	rmd_sim_motor_params_default(&p, 1, RMD_PROTO_V3);
	p.personality = rec;
	rmd_sim_motor_init(&m, &p, 0);
	for (unsigned c = 0; c < 256; c += 7) {
		const struct rmd_personality_turnaround *t =
			rmd_personality_turnaround_for(&m.p.personality, c);

		req.data[0] = (uint8_t)c;
		FUZZ_CHECK(rmd_sim_motor_receive(&m, (int64_t)c * 100000, &req, out, 8) <= 8);
		for (double u = 0.0; t && u < 1.0; u += 0.0625) {
			int64_t ns = rmd_personality_turnaround_ns(t, u);

			FUZZ_CHECK(ns >= (int64_t)t->q_us[0] * 1000 &&
				   ns <= (int64_t)t->q_us[RMD_PERSONALITY_NQ - 1] * 1000);
		}
	}
	return 0;
}
