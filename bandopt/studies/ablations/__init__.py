"""The ablation studies: each module holds one `Study` configuration
(`STUDY`), its README section and what it adds to the summary; one study
per question about the estimator, run by `make study NAME=...`.

- `mix`: same-class blends in the prior;
- `noise`: a band-error model per metric;
- `intervals`: the conformal interval unit;
- `shift`: wavelength-shifted direct-emission LEDs in the prior;
- `planck`: modelled incandescent (Planck) spectra in the prior;
- `defaults`: `bandopt evaluate`'s estimator as a whole;
- `tm30`: the IES TM-30-15 lamps in the prior;
- `bands`: how many bands the goal needs (contiguous band sets, and the
  library-free direct estimate)."""
