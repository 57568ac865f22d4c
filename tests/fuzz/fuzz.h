/* SPDX-License-Identifier: MIT */
/*
 * What the harnesses share: libFuzzer's entry points, a check that aborts
 * (libFuzzer saves the input as a crash), and a reader that takes typed
 * values off the input.
 */
#ifndef RMD_FUZZ_H
#define RMD_FUZZ_H

#include <errno.h>
#include <stdbool.h>
#include <stddef.h>
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <unistd.h>

int LLVMFuzzerTestOneInput(const uint8_t *data, size_t size);
int LLVMFuzzerInitialize(int *argc, char ***argv);

/* A property the code under test promises: its failure is a finding. */
#define FUZZ_CHECK(cond)                                                                         \
	do {                                                                                     \
		if (!(cond)) {                                                                   \
			fprintf(stderr, "%s:%d: check failed: %s\n", __FILE__, __LINE__, #cond); \
			abort();                                                                 \
		}                                                                                \
	} while (0)

/*
 * A defect the harness found that is reported and not fixed yet
 * (tests/fuzz/README.md, "Known defects"): inputs that reach it are
 * skipped, so that the harness keeps looking for the next one and CI stays
 * green.  Its crashing input is already in the corpus: remove the line with
 * the fix, and the corpus run proves the fix.
 */
#define FUZZ_KNOWN(cond, defect)  \
	do {                      \
		if (cond)         \
			return 0; \
	} while (0)

/* The input, read front to back; past its end every value is zero. */
struct fuzz_in {
	const uint8_t *p;
	size_t n;
};

static inline void fuzz_take(struct fuzz_in *in, void *out, size_t len)
{
	size_t k = in->n < len ? in->n : len;

	memset(out, 0, len);
	if (k)
		memcpy(out, in->p, k);
	in->p += k;
	in->n -= k;
}

/* fuzz_u8(), fuzz_u16(), fuzz_u64(), fuzz_f64(): the next value, in the host's byte order. */
#define FUZZ_READER(name, type)                     \
	static inline type name(struct fuzz_in *in) \
	{                                           \
		type v;                             \
		fuzz_take(in, &v, sizeof(v));       \
		return v;                           \
	}
FUZZ_READER(fuzz_u8, uint8_t)
FUZZ_READER(fuzz_u16, uint16_t)
FUZZ_READER(fuzz_u64, uint64_t)
FUZZ_READER(fuzz_f64, double)

/*
 * The input as the contents of a file, for loaders that take a path: one
 * temporary file per process, rewritten for each input, removed at exit.
 * Returns its path.
 */
const char *fuzz_file(const uint8_t *data, size_t size);

#endif /* RMD_FUZZ_H */
