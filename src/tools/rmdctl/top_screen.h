/* SPDX-License-Identifier: MIT */
/*
 * rmdctl top's screen on a terminal (ncurses): it draws a struct top_view
 * and reads the keys; top.c runs the loop, receives LCM and applies what
 * the keys ask for.  Non-rt.
 */
#ifndef RMDCTL_TOP_SCREEN_H
#define RMDCTL_TOP_SCREEN_H

#include "top_view.h"

/* What the keys typed since the last top_screen_keys() ask for (bits). */
#define TOP_SCREEN_KEYED 0x1u /* a key came (a resize too): draw again */
#define TOP_SCREEN_PAUSE 0x2u /* toggle the pause (an odd number of p or space) */
#define TOP_SCREEN_QUIT 0x4u  /* q */

struct top_screen;

/* The terminal in curses mode; NULL when curses cannot drive it. */
struct top_screen *top_screen_open(void);
/*
 * The whole screen from v[0..n-1]: one daemon (n 1), or several of one
 * robot (--prefix A_,B_: each motor with its instance, a line each).
 */
void top_screen_draw(struct top_screen *s, const struct top_view *v, int n);
/* Every key typed since the last call: the picked motor moves; returns TOP_SCREEN_* bits. */
unsigned int top_screen_keys(struct top_screen *s, const struct top_view *v, int n);
/* The terminal restored; s freed. */
void top_screen_close(struct top_screen *s);

#endif /* RMDCTL_TOP_SCREEN_H */
