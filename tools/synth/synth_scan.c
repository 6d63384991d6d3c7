/* synth_scan.c - `wpd synth`'s acquisition (see synth_scan.h): the line
 * spacing controller that makes the count exact, the scan lines and
 * strips, and the attributes of each echo.
 *
 * The whole scan draws from one random stream in a fixed order, so the
 * points depend on (points, seed) only.
 */
#include "tools/synth/synth_scan.h"

#include <string.h>

#define TURN_TIME 90.0          /* s between strips */
#define GPS_START 335000000.0   /* adjusted standard GPS time of the first pulse */

/* Class, intensity and colour of each material (enum material). */
static const uint8_t material_class[MAT_COUNT] = {2, 2, 6, 6, 5, 7};
static const double material_intensity[MAT_COUNT] = {21000, 9000, 27000, 15000, 17000, 5000};
static const uint8_t material_rgb[MAT_COUNT][3] = {
    {128, 100, 70}, {78, 76, 74}, {140, 140, 142}, {165, 155, 140}, {62, 112, 52}, {200, 200, 200},
};

void synth_scan_init(scan *s, const scene *sc, const flight *fl, emitter *em, uint64_t seed,
                     int creases)
{
    memset(s, 0, sizeof *s);
    s->sc = sc, s->fl = fl, s->em = em, s->time = GPS_START;
    /* Half the point spacing: the band of the ground truth (synth_creases.h). */
    synth_tracer_init(&s->tr, sc, creases ? 0.5 * fl->point_spacing : 0);
    rng_seed(&s->g, seed);
}

/* Along-track spacing for the next line: what makes the points still needed
 * fit the scan still to fly, a few lines early (clamped to 0.5 .. 2 times
 * the nominal spacing; the exact stop is at the N-th point). */
static double next_line_spacing(const scan *s, int strip, double flown)
{
    const flight *f = s->fl;
    double need = (double)(s->em->target - s->em->written);
    double per_pulse = (s->echoes + RETURNS_PRIOR * 20000.0) / (s->pulses + 20000.0);
    double ahead = (double)f->inside[strip] * max2(0, s->sc->side - flown);
    for (int i = strip + 1; i < f->strips; i++)
        ahead += (double)f->inside[i] * s->sc->side;
    double margin = 3.0 * f->inside[strip] * per_pulse;
    double dy = ahead * per_pulse / (need + margin);
    return clampd(dy, 0.5 * f->line_spacing, 2.0 * f->line_spacing);
}

/* Class, intensity and colour of echo p->ret of p->nret: intensity by
 * surface, lower off nadir (gain) and for later returns of a split pulse,
 * with noise; colour by surface with a brightness and per-channel jitter. */
static void shade_point(rng *g, point *p, const echo *e, double gain, double noise)
{
    /* Share of the pulse energy of return r of a split pulse. */
    static const double split_energy[MAX_RETURNS + 1] = {0, 0.8, 0.275, 0.183, 0.138, 0.11};
    int m = e->material;
    double energy = p->nret > 1 ? split_energy[p->ret] : 1.0;
    double base = material_intensity[m] * (m == MAT_ROOF ? e->shade : 1.0);
    double i = base * energy * gain * (1 + 0.3 * noise);
    p->intensity = (int)clampd(i + 0.5, 0, 65535);
    /* Colour in integers: brightness 0.94 .. 1.06 (times the roof's shade,
     * 0.75 .. 1.25), then -8 .. +7 per channel. Every material colour stays
     * within 0 .. 255 after both. */
    uint64_t bits = rng_next(g);
    int tone = (int)((m == MAT_ROOF ? e->shade : 1.0) * (240 + (int)(bits & 31)));
    for (int c = 0; c < 3; c++)
        p->rgb[c] = ((material_rgb[m][c] * tone) >> 8) + (int)((bits >> (8 + 8 * c)) & 15) - 8;
    p->cls = material_class[m];
}

/* Emits the echoes of one pulse (stopping at the target count). */
static int emit_pulse(scan *s, point *p, const echo *ech, int n, double gain, double along,
                      wpd_error *err)
{
    emitter *em = s->em;
    p->nret = n;
    for (int i = 0; i < n && em->written < em->target; i++) {
        uint64_t bits = rng_next(&s->g);
        p->ret = i + 1;
        if (s->tr.transposed)    /* the echo's x is the scene's y */
            p->x = along, p->y = ech[i].x;
        else
            p->x = ech[i].x;
        p->crease = ech[i].crease;
        p->z = ech[i].z + 0.05 * tri_noise((uint32_t)bits);   /* ranging noise, sd 2 cm */
        shade_point(&s->g, p, &ech[i], gain, tri_noise((uint32_t)(bits >> 32)));
        if (synth_emit_point(em, p, err))
            return -1;
    }
    return 0;
}

/* Flies one scan line of strip `strip` at along-track position `flown`. */
static int fly_line(scan *s, int strip, int source, int line, double flown, double dy,
                    wpd_error *err)
{
    const flight *f = s->fl;
    const int m = f->pulses_per_line, north = strip % 2 == 0, forward = line % 2 == 0;
    double L = s->sc->side, dt = f->line_period / m, pulse_dy = dy / m;
    ray r = {strip_centre(f, strip), 0, f->altitude, 0};
    /* Time steps j whose scan step (j or m-1-j) lands in the scene. */
    int j0 = forward ? f->lo[strip] : m - f->hi[strip];
    int j1 = forward ? f->hi[strip] : m - f->lo[strip];
    point p;
    memset(&p, 0, sizeof p);
    p.source = source;
    p.scan_dir = forward == north;   /* positive: left to right of the heading */
    echo ech[MAX_RETURNS];
    for (int j = j0; j < j1 && s->em->written < s->em->target; j++) {
        int step = forward ? j : m - 1 - j;
        double along = flown + pulse_dy * j;
        if (along > L)
            break;
        r.y = north ? along : L - along;
        r.s = f->tan_of[step];
        int n = synth_trace_pulse(&s->tr, &s->g, &r, ech);
        if (!n)
            continue;
        s->pulses++, s->echoes += (uint64_t)n;
        p.y = r.y;
        p.gps_time = s->time + j * dt;
        p.edge = j == m - 1;
        p.angle = north ? f->rank_of[step] : -f->rank_of[step];
        if (emit_pulse(s, &p, ech, n, f->gain_of[step], r.y, err))
            return -1;
    }
    return 0;
}

/* Flies one strip; `source` is its point source id. */
static int fly_strip(scan *s, int strip, int source, wpd_error *err)
{
    const flight *f = s->fl;
    synth_tracer_orient(&s->tr, strip_transposed(f, strip), f->per_direction < f->strips);
    double L = s->sc->side;
    uint64_t h = feature_hash(s->sc->seed, 5, source, 0, 0);
    double wobble_phase = hash_unit(h, 0), wobble_length = 500 + 400 * hash_unit(h, 1);
    uint64_t before = s->em->written;
    double flown = 0;
    for (int line = 0; flown <= L && s->em->written < s->em->target; line++) {
        double dy = next_line_spacing(s, strip, flown);
        dy *= 1 + 0.08 * sin_table(s->sc->sine, flown / wobble_length + wobble_phase);
        if (fly_line(s, strip, source, line, flown, dy, err))
            return -1;
        flown += dy;
        s->time += s->fl->line_period;
    }
    s->time += TURN_TIME;
    if (s->em->written > before)
        s->strips_used++;
    return 0;
}

/* Flies the strips (again, with new source ids, in the rare case that one
 * pass falls short) until the target count is written. */
int synth_fly(scan *s, wpd_error *err)
{
    const flight *f = s->fl;
    for (int pass = 0; s->em->written < s->em->target; pass++) {
        uint64_t before = s->em->written;
        for (int i = 0; i < f->strips && s->em->written < s->em->target; i++)
            if (f->inside[i] && fly_strip(s, i, (pass * f->strips + i) % 65535 + 1, err))
                return -1;
        if (s->em->written == before)    /* cannot happen: every pass sees the scene */
            return wpd_fail(err, WPD_E_INPUT, "%s: internal error: a flight pass recorded no points",
                            s->em->opt->output);
    }
    return 0;
}
