/* heap.h - handing freed heap memory back to the system between phases. */
#ifndef WPD_HEAP_H
#define WPD_HEAP_H

/* Gives the whole free pages of the heap back to the system. The CLI keeps
 * freed memory in the heap (mallopt in cli/main.c) so that the arrays of one
 * tile after another are reused without page faults; but a phase whose
 * arrays are shaped differently (the flat sample set after the tiles, the
 * smoothing grids after it) cannot reuse the holes and grows the heap
 * instead, and the holes' pages stay resident under the next phase's peak.
 * Called between phases (a few times a run). A no-op without glibc. */
void wpd_heap_release(void);

#endif
