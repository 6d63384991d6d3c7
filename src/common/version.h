/* version.h - wpd's version, printed by --version and written, after
 * "wpd ", as the generating software of every LAS and LAZ file wpd
 * writes. Readers tell wpd's files apart by it: a layered LAZ file whose
 * generating software is "wpd" alone (WPD_SOFTWARE_OLD) comes from a wpd
 * before 0.2.0, whose colour, NIR and extra-byte items took the wrong
 * context after a scanner channel change (docs/formats.md, "Scanner
 * channels"). */
#ifndef WPD_VERSION_H
#define WPD_VERSION_H

#define WPD_VERSION "0.2.0"
#define WPD_SOFTWARE "wpd " WPD_VERSION
#define WPD_SOFTWARE_OLD "wpd"

#endif
