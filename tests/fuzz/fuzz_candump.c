// SPDX-License-Identifier: MIT
/*
 * can-utils text (rmd_candump_parse()): any bytes as one line.  The error
 * span lies inside the line and has a name; a line that parses prints back
 * as "ID#DATA" and parses again to the same frame.
 *
 * Input: the line (a NUL in it ends it, as in a C string).
 */
#include <stddef.h>
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "rmd/candump.h"

#include "fuzz.h"

int LLVMFuzzerTestOneInput(const uint8_t *data, size_t size)
{
	struct rmd_candump_line out, again;
	char *line = malloc(size + 1), text[64];
	size_t len, n;
	int r;

	if (!line)
		return 0;
	memcpy(line, data, size);
	line[size] = '\0';
	len = strlen(line);

	r = rmd_candump_parse(line, &out);
	FUZZ_CHECK(r == 0 || r == -ENODATA || r == -ERANGE || r == -EOPNOTSUPP || r == -EINVAL);
	FUZZ_CHECK(out.err < RMD_CANDUMP_ERR_COUNT);
	FUZZ_CHECK(rmd_candump_strerror(out.err) != NULL);
	FUZZ_CHECK((r == 0) == (out.err == RMD_CANDUMP_OK));
	if (r < 0) {
		FUZZ_CHECK((size_t)out.err_off + out.err_len <= len);
		free(line);
		return 0;
	}
	FUZZ_CHECK(out.frame.can_id <= RMD_CANDUMP_MAX_ID);
	FUZZ_CHECK(out.frame.len <= RMD_FRAME_LEN);
	FUZZ_CHECK(memchr(out.iface, 0, sizeof(out.iface)) != NULL);
	FUZZ_CHECK(out.time_digits <= 9);

	n = (size_t)snprintf(text, sizeof(text), "%03X#", (unsigned)out.frame.can_id);
	for (unsigned i = 0; i < out.frame.len; i++)
		n += (size_t)snprintf(text + n, sizeof(text) - n, "%02X", out.frame.data[i]);
	r = rmd_candump_parse(text, &again);
	FUZZ_CHECK(r == 0);
	FUZZ_CHECK(again.frame.can_id == out.frame.can_id && again.frame.len == out.frame.len);
	FUZZ_CHECK(memcmp(again.frame.data, out.frame.data, out.frame.len) == 0);
	free(line);
	return 0;
}
