// SPDX-License-Identifier: MIT
/* Set-up of the lock-free hand-overs; the hot paths are inline in rmd/spsc.h. */
#include <errno.h>

#include "rmd/spsc.h"

int rmd_ring_init(struct rmd_ring *r, void *buf, size_t slots, size_t rec_size)
{
	if (!buf || slots < 2 || (slots & (slots - 1)) || !rec_size)
		return -EINVAL;
	atomic_init(&r->head, 0);
	atomic_init(&r->tail, 0);
	atomic_init(&r->dropped, 0);
	r->mask = slots - 1;
	r->rec_size = rec_size;
	r->buf = buf;
	return 0;
}

void rmd_latest_init(struct rmd_latest *l, void *buf, size_t size)
{
	unsigned char *p = buf;

	for (unsigned i = 0; i < 3; i++)
		l->slot[i] = p + i * size;
	l->size = size;
	l->write_idx = 0;
	l->read_idx = 1;
	atomic_init(&l->state, 2u);
	atomic_init(&l->published, 0);
}
