/* synth_trace.h - where one pulse of `wpd synth`'s scanner meets the
 * scene, and the echoes it returns: the first solid surface (ground, roof,
 * wall), up to MAX_RETURNS returns through a tree crown, or now and then a
 * single noise outlier. Implemented by synth_trace.c.
 */
#ifndef WPD_SYNTH_TRACE_H
#define WPD_SYNTH_TRACE_H

#include "tools/synth/synth_math.h"
#include "tools/synth/synth_scene.h"

#define MAX_RETURNS 5

/* A pulse: a straight ray from the aircraft at (xa, y, za) leaning across
 * track; descending by 1 m moves it s metres in x. In a transposed tracer
 * (east/west strips) x and y are the scene's y and x, and so are an
 * echo's x and the ray's y. */
typedef struct ray { double xa, y, za, s; } ray;

/* One return, in local coordinates, before the acquisition attributes;
 * crease: the kind of building crease it lies on (synth_creases.h), when
 * asked for; 0 otherwise. */
typedef struct echo { double x, z; int material; double shade; int crease; } echo;

/* Per-scan lookup state: caches of scene features (each lookup kind its
 * own, so they do not evict each other) and the last ground height. */
typedef struct tracer {
    const scene *sc;
    block_info blocks[4];        /* ground lot, roof-level lot, lots between, trees */
    building lots[3];            /* lot under the ground hit, lot at roof level, between */
    tree trees[3];               /* two kerb directions, park */
    double ground_guess;         /* ground height of the previous pulse */
    double crease_band;          /* > 0: mark the echoes within it of a crease */
    int steep;                   /* 1: rays may lean so far (the oblique survey) that they
                                    pass over lots between those two: look there too */
    int transposed;              /* 1: rays lean along y (east/west strips): the ray's
                                    x is the scene's y and its y the scene's x */
} tracer;

/* A tracer for scene sc (which must outlive it), with empty caches;
 * crease_band > 0: set each echo's crease kind for that band (half the
 * point spacing; synth_creases.h), else it stays 0. */
void synth_tracer_init(tracer *tr, const scene *sc, double crease_band);

/* Sets the direction of the rays that follow: transposed 1 for east/west
 * strips (see ray), 0 for north/south ones; steep 1 for the oblique survey. */
void synth_tracer_orient(tracer *tr, int transposed, int steep);

/* Traces ray r, drawing from g; returns the number of echoes (1 ..
 * MAX_RETURNS, written to out in return order), or 0 when one of them
 * falls outside the scene square (the whole pulse is then not recorded, so
 * the bounds are the scene's and every recorded pulse is complete). */
int synth_trace_pulse(tracer *tr, rng *g, const ray *r, echo out[MAX_RETURNS]);

#endif
