/* pass.c - one streaming pass over the inputs on several threads (see
 * pass.h).
 *
 * Ordered passes hand out turns: every work item (a unit when reading in
 * parallel, a batch when reading serially) gets a sequence number when it
 * is taken, and its commits wait until every earlier item has passed its
 * turn. Items are taken in increasing order and each one passes its turn
 * exactly once, failed or not, so a lane waiting for its turn always waits
 * on items that are being worked on. The lanes run without a join per
 * batch: a team that joins per batch stalls whenever one of its threads is
 * descheduled.
 */
#include "io/pass.h"

#include <omp.h>
#include <pthread.h>
#include <stdatomic.h>
#include <stdlib.h>
#include <string.h>

#include "common/first_error.h"
#include "io/reader.h"

typedef struct lane {
    wpd_cloud *cloud;         /* parallel reading: the lane's own */
    wpd_batch batch;
} lane;

typedef struct pass_state {
    const wpd_pass *p;
    lane *lanes;              /* [p->threads] */
    int parallel;             /* units read in parallel, else serial reading */
    uint64_t end;             /* records [0, end) */
    /* parallel reading */
    uint64_t unit;            /* records per unit: a batch's capacity */
    int nfiles;
    uint64_t *file_first;     /* [nfiles] first record of each file */
    uint64_t *file_unit;      /* [nfiles] records per unit of each file */
    uint64_t **file_starts;   /* [nfiles] first records of a file's units, from
                                 its first (LAZ with chunks of varying size);
                                 NULL: units of file_unit records */
    uint64_t *unit_first;     /* [nfiles + 1] first unit of each file; the last: all units */
    _Atomic uint64_t next_unit;
    /* serial reading, under mu */
    wpd_cloud *shared;
    int done;
    uint64_t next_seq, read_gid;
    /* ordered passes */
    pthread_mutex_t mu;
    pthread_cond_t turn;      /* next_turn moved on */
    uint64_t next_turn;       /* under mu */
    uint64_t commit_gid;      /* global index of the next committed point: the
                                 turn's holder's alone */
    _Atomic int stopped;      /* a commit said the pass needs no more */
    wpd_first_error fe;
} pass_state;

size_t wpd_pass_lane_bytes(const wpd_cloud *c)
{
    /* The batch, and a cloud's copies of the headers; a seekable reader
     * keeps no buffer of its own. */
    return wpd_batch_bytes(wpd_cloud_header(c, 0)->schema.record_size) +
           (size_t)wpd_cloud_nfiles(c) * sizeof(wpd_header);
}

static void wait_turn(pass_state *s, uint64_t seq)
{
    pthread_mutex_lock(&s->mu);
    while (s->next_turn != seq)
        pthread_cond_wait(&s->turn, &s->mu);
    pthread_mutex_unlock(&s->mu);
}

static void pass_turn(pass_state *s)
{
    pthread_mutex_lock(&s->mu);
    s->next_turn++;
    pthread_cond_broadcast(&s->turn);
    pthread_mutex_unlock(&s->mu);
}

/* Commits pb (the turn is held). Returns 0 or -1 with err set. */
static int commit(pass_state *s, wpd_pass_batch *pb, wpd_error *err)
{
    /* No commit after a failure: the mutex of the turns orders this check
     * after any failure of an earlier commit. */
    if (wpd_first_error_failed(&s->fe) || atomic_load(&s->stopped))
        return 0;
    pb->first_gid = s->commit_gid;
    int rc = s->p->commit(s->p->arg, pb, err);
    if (rc < 0)
        return -1;
    if (rc > 0)
        atomic_store(&s->stopped, 1);
    s->commit_gid += pb->batch->n;
    wpd_progress_add(s->p->progress, pb->batch->n);
    return 0;
}

/* Unit u: its file, first record and records. */
static void unit_range(const pass_state *s, uint64_t u, uint64_t *first, uint64_t *count)
{
    int lo = 0, hi = s->nfiles - 1; /* the last file whose first unit is <= u */
    while (lo < hi) {
        int mid = (lo + hi + 1) / 2;
        if (s->unit_first[mid] <= u)
            lo = mid;
        else
            hi = mid - 1;
    }
    uint64_t k = u - s->unit_first[lo];
    if (s->file_starts[lo]) {
        *first = s->file_first[lo] + s->file_starts[lo][k];
        *count = s->file_starts[lo][k + 1] - s->file_starts[lo][k];
        return;
    }
    uint64_t unit = s->file_unit[lo];
    *first = s->file_first[lo] + k * unit;
    *count = s->end - *first < unit ? s->end - *first : unit;
}

/* Reads unit u with l's cloud and hands its batches on. A unit normally
 * comes in one batch (its records fit one); should a reader cut it, the
 * later batches are committed within the same turn. */
static void run_unit(pass_state *s, int l, uint64_t u)
{
    const wpd_pass *p = s->p;
    lane *ln = &s->lanes[l];
    uint64_t first, count;
    unit_range(s, u, &first, &count);
    wpd_error err = {0};
    int ok = wpd_cloud_seek_stretch(ln->cloud, first, count, &err) == 0;
    uint64_t gid = p->every_record_finite ? first : WPD_PASS_GID_UNKNOWN;
    int have_turn = 0;
    while (ok && !wpd_first_error_failed(&s->fe)) {
        wpd_pass_batch pb = {&ln->batch, 0, l, gid, u};
        long got = wpd_cloud_read(ln->cloud, &ln->batch, &pb.file, &err);
        if (got <= 0) {
            ok = got == 0;
            break;
        }
        if (p->lane && p->lane(p->arg, &pb, &err)) {
            ok = 0;
            break;
        }
        if (gid != WPD_PASS_GID_UNKNOWN)
            gid += (uint64_t)got;
        if (p->commit) {
            if (!have_turn)
                wait_turn(s, u);
            have_turn = 1;
            ok = commit(s, &pb, &err) == 0;
        } else {
            wpd_progress_add(p->progress, (uint64_t)got);
        }
    }
    if (!ok)
        wpd_first_error_keep(&s->fe, &err);
    if (p->commit) {
        if (!have_turn)
            wait_turn(s, u);
        pass_turn(s);
    }
}

static void run_parallel(pass_state *s, int l)
{
    while (!wpd_first_error_failed(&s->fe) && !atomic_load(&s->stopped)) {
        uint64_t u = atomic_fetch_add(&s->next_unit, 1);
        if (u >= s->unit_first[s->nfiles])
            break;
        if (s->p->shares < 2 || u % (uint64_t)s->p->shares == (uint64_t)s->p->share)
            run_unit(s, l, u);
    }
}

/* Records the shared cloud has gone through: every record is a delivered
 * point, a dropped one or one its filter skipped. */
static uint64_t records_read(const wpd_cloud *c)
{
    uint64_t n = wpd_cloud_dropped(c) + wpd_cloud_filtered(c);
    for (int f = 0; f < wpd_cloud_nfiles(c); f++)
        n += wpd_cloud_delivered(c, f);
    return n;
}

static void run_serial(pass_state *s, int l)
{
    const wpd_pass *p = s->p;
    lane *ln = &s->lanes[l];
    for (;;) {
        wpd_error err = {0};
        wpd_pass_batch pb = {&ln->batch, 0, l, 0, WPD_PASS_NO_UNIT};
        long got = 0;
        uint64_t seq = 0;
        pthread_mutex_lock(&s->mu);
        if (!s->done && !wpd_first_error_failed(&s->fe) && !atomic_load(&s->stopped)) {
            got = wpd_cloud_read(s->shared, &ln->batch, &pb.file, &err);
            if (got > 0) {
                seq = s->next_seq++;
                pb.first_gid = s->read_gid;
                s->read_gid += (uint64_t)got;
            }
            if (got <= 0 || (s->end < wpd_cloud_count(s->shared) &&
                             records_read(s->shared) >= s->end))
                s->done = 1;
        }
        pthread_mutex_unlock(&s->mu);
        if (got < 0)
            wpd_first_error_keep(&s->fe, &err);
        if (got <= 0)
            break;
        int mine = p->shares < 2 || seq % (uint64_t)p->shares == (uint64_t)p->share;
        int ok = !mine || !p->lane || p->lane(p->arg, &pb, &err) == 0;
        if (p->commit) {
            wait_turn(s, seq); /* taken: passed even after a failure */
            ok = ok && commit(s, &pb, &err) == 0;
            pass_turn(s);
        } else if (ok) {
            wpd_progress_add(p->progress, (uint64_t)got);
        }
        if (!ok)
            wpd_first_error_keep(&s->fe, &err);
    }
}

/* Records per unit of file f: a batch's, or for LAZ in chunks of a fixed
 * size, whole chunks (as many as a batch holds, or one larger than a
 * batch): a lane then decodes whole chunks, never the head of a chunk that
 * another lane decodes too (with units of a batch and LASzip's chunks of
 * 50 000 points, that was 38 % more decoding). */
static uint64_t file_unit(const wpd_cloud *c, int f, uint64_t cap)
{
    const wpd_header *h = wpd_cloud_header(c, f);
    const wpd_laz_info *z = &h->las.laz;
    if (h->format != WPD_FMT_LAS || !z->compressed || z->compressor < 2 || !z->chunks ||
        z->chunk_size == 0 || z->chunk_size == UINT32_MAX || z->chunk_size > WPD_PASS_MAX_UNIT)
        return cap;
    return z->chunk_size > cap ? z->chunk_size : cap / z->chunk_size * z->chunk_size;
}

/* Units of whole chunks for a LAZ file whose chunk table gives chunks of
 * varying size (COPC: one chunk per octree node): *starts (NULL when the
 * file has none such, or a chunk too large for a unit) and their number,
 * for its first n records. Returns 0, or -1 with err set. */
static int varying_chunk_units(const wpd_header *h, uint64_t n, uint64_t cap, uint64_t **starts,
                               uint64_t *units, wpd_error *err)
{
    const wpd_laz_info *z = &h->las.laz;
    *starts = NULL;
    if (h->format != WPD_FMT_LAS || !z->compressed || z->compressor < 2 || !z->chunks ||
        (z->chunk_size && z->chunk_size != UINT32_MAX) || !n)
        return 0;
    wpd_reader *r = wpd_reader_open(h->path, err);
    if (!r)
        return -1;
    const uint64_t *first;
    uint64_t nchunks = wpd_reader_chunks(r, &first), largest = 0;
    for (uint64_t c = 0; c < nchunks; c++)
        largest = first[c + 1] - first[c] > largest ? first[c + 1] - first[c] : largest;
    int rc = 0;
    if (nchunks && largest <= WPD_PASS_MAX_UNIT) {
        if ((*starts = malloc(((size_t)nchunks + 1) * sizeof **starts)))
            *units = wpd_chunk_units(first, nchunks, n, cap, *starts);
        else
            rc = wpd_fail(err, WPD_E_MEMORY, "out of memory for reading");
    }
    wpd_reader_close(r);
    return rc;
}

/* Units of each file within records [0, end). Returns 0, or -1 with err
 * set. */
static int plan_units(pass_state *s, wpd_error *err)
{
    const wpd_cloud *c = s->p->cloud;
    s->nfiles = wpd_cloud_nfiles(c);
    s->file_first = malloc((size_t)s->nfiles * sizeof *s->file_first);
    s->file_unit = malloc((size_t)s->nfiles * sizeof *s->file_unit);
    s->file_starts = calloc((size_t)s->nfiles, sizeof *s->file_starts);
    s->unit_first = malloc(((size_t)s->nfiles + 1) * sizeof *s->unit_first);
    if (!s->file_first || !s->file_unit || !s->file_starts || !s->unit_first)
        return wpd_fail(err, WPD_E_MEMORY, "out of memory for reading");
    uint64_t record = 0, units = 0;
    for (int f = 0; f < s->nfiles; f++) {
        const wpd_header *h = wpd_cloud_header(c, f);
        uint64_t n = h->point_count, varying = 0;
        uint64_t in = record >= s->end ? 0 : s->end - record < n ? s->end - record : n;
        s->file_first[f] = record;
        s->file_unit[f] = file_unit(c, f, s->unit);
        s->unit_first[f] = units;
        if (varying_chunk_units(h, in, s->unit, &s->file_starts[f], &varying, err))
            return -1;
        units += s->file_starts[f] ? varying : (in + s->file_unit[f] - 1) / s->file_unit[f];
        record += n;
    }
    s->unit_first[s->nfiles] = units;
    return 0;
}

/* Records a lane's batch holds (wpd_batch_init's capacity): the unit. */
static uint64_t batch_capacity(uint32_t record_size)
{
    size_t most = WPD_BATCH_MAX_BYTES / (record_size ? record_size : 1);
    return WPD_BATCH_POINTS > most ? (most ? most : 1) : WPD_BATCH_POINTS;
}

int wpd_pass_units(const wpd_cloud *c, uint64_t *units, wpd_error *err)
{
    *units = 0;
    if (!wpd_cloud_can_seek(c))
        return 0;
    wpd_pass p = {.cloud = (wpd_cloud *)c};
    pass_state s = {.p = &p, .end = wpd_cloud_count(c),
                    .unit = batch_capacity(wpd_cloud_header(c, 0)->schema.record_size)};
    int rc = plan_units(&s, err);
    if (rc == 0)
        *units = s.unit_first[s.nfiles];
    free(s.file_first);
    free(s.unit_first);
    free(s.file_unit);
    for (int f = 0; s.file_starts && f < s.nfiles; f++)
        free(s.file_starts[f]);
    free(s.file_starts);
    return rc;
}

/* The lanes' batches and clouds, and the units. */
static int setup(pass_state *s, wpd_error *err)
{
    const wpd_pass *p = s->p;
    uint32_t rs = wpd_cloud_header(p->cloud, 0)->schema.record_size;
    if (!(s->lanes = calloc((size_t)p->threads, sizeof *s->lanes)))
        return wpd_fail(err, WPD_E_MEMORY, "out of memory for reading");
    for (int l = 0; l < p->threads; l++)
        if (wpd_batch_init(&s->lanes[l].batch, WPD_BATCH_POINTS, rs))
            return wpd_fail(err, WPD_E_MEMORY, "out of memory for reading");
    if (!s->parallel)
        return (s->shared = wpd_cloud_reopen(p->cloud, err)) ? 0 : -1;
    /* One batch holds a unit: every lane's batch has the same capacity. */
    s->unit = s->lanes[0].batch.cap;
    if (s->unit != batch_capacity(rs))
        return wpd_fail(err, WPD_E_USAGE, "internal error: a unit is not a batch");
    if (plan_units(s, err))
        return -1;
    atomic_store(&s->next_unit, p->first_unit);
    s->next_turn = p->first_unit;
    s->commit_gid = p->first_gid;
    /* Each lane's reader of the first file is opened here, before any
     * point is read: a file that shrinks while it is read then fails as
     * "ends after" in the reads, never in a late lane's header. */
    for (int l = 0; l < p->threads; l++)
        if (!(s->lanes[l].cloud = wpd_cloud_reopen(p->cloud, err)) ||
            wpd_cloud_seek_stretch(s->lanes[l].cloud, 0, 0, err))
            return -1;
    return 0;
}

/* A pass over the whole cloud leaves its counts as one reading would. */
static void hand_back_counts(const pass_state *s)
{
    wpd_cloud *c = s->p->cloud;
    wpd_error ignored;
    wpd_cloud_rewind(c, &ignored); /* cannot fail: it only closes */
    if (s->shared)
        wpd_cloud_add_counts(c, s->shared);
    for (int l = 0; l < s->p->threads; l++)
        if (s->lanes[l].cloud)
            wpd_cloud_add_counts(c, s->lanes[l].cloud);
}

/* The non-finite points this process's reading dropped (wpd_pass.dropped). */
static uint64_t dropped_here(const pass_state *s)
{
    uint64_t n = 0;
    if (s->shared && (s->p->shares < 2 || s->p->share == 0))
        n += wpd_cloud_dropped(s->shared);
    for (int l = 0; s->lanes && l < s->p->threads; l++)
        if (s->lanes[l].cloud)
            n += wpd_cloud_dropped(s->lanes[l].cloud);
    return n;
}

static void teardown(pass_state *s)
{
    for (int l = 0; s->lanes && l < s->p->threads; l++) {
        wpd_cloud_close(s->lanes[l].cloud);
        wpd_batch_free(&s->lanes[l].batch);
    }
    wpd_cloud_close(s->shared);
    free(s->lanes);
    free(s->file_first);
    free(s->unit_first);
    free(s->file_unit);
    for (int f = 0; s->file_starts && f < s->nfiles; f++)
        free(s->file_starts[f]);
    free(s->file_starts);
}

int wpd_pass_run(const wpd_pass *p, wpd_error *err)
{
    pass_state s = {.p = p};
    uint64_t records = wpd_cloud_count(p->cloud);
    int whole = p->end == 0 || p->end >= records;
    s.end = whole ? records : p->end;
    /* Serial with one lane too: seeking buys nothing there, unless the
     * units are shared with other processes (which then skip the others'). */
    s.parallel = (p->threads > 1 || p->shares > 1 || p->first_unit) &&
                 wpd_cloud_can_seek(p->cloud);
    if (p->first_unit && !s.parallel)
        return wpd_fail(err, WPD_E_USAGE, "internal error: a pass from unit %llu of a cloud "
                        "that cannot seek", (unsigned long long)p->first_unit);
    pthread_mutex_init(&s.mu, NULL);
    pthread_cond_init(&s.turn, NULL);
    int rc = setup(&s, err);
    if (rc == 0) {
#pragma omp parallel num_threads(p->threads)
        {
            int l = omp_get_thread_num();
            if (s.parallel)
                run_parallel(&s, l);
            else
                run_serial(&s, l);
        }
        rc = wpd_first_error_take(&s.fe, err);
    }
    if (rc == 0 && p->dropped)
        *p->dropped = dropped_here(&s);
    if (rc == 0 && whole && p->shares < 2 && !p->first_unit && !atomic_load(&s.stopped))
        hand_back_counts(&s);
    teardown(&s);
    pthread_mutex_destroy(&s.mu);
    pthread_cond_destroy(&s.turn);
    return rc;
}
