"""The physics of the water, one idea per module, all pure functions of their arguments.

- `propagation`: transmission loss, practical spreading plus Thorp's absorption;
- `noise`: ambient noise spectra (turbulence, shipping, wind, thermal) and their band level;
- `modulation`: bit and frame error rates of PSK/FSK, or a per-modem SNR-to-error table;
- `fading`: block fading of a frame (Rayleigh/Rician power gain), sampled or averaged;
- `modems`: the `Modem` parameters and the named presets, with where each number comes from;
- `budget`: `LinkBudget`, the sonar equation SNR = SL - TL - NL put together for one channel.

References (cited again where used):
- M. Stojanovic, "On the relationship between capacity and distance in an underwater acoustic
  communication channel", ACM SIGMOBILE MC2R 11(4), 2007 (spreading, Thorp, noise spectra).
- R. J. Urick, *Principles of Underwater Sound*, 3rd ed., McGraw-Hill, 1983 (sonar equation).
- J. G. Proakis, *Digital Communications*, 4th ed., McGraw-Hill, 2001 (PSK/FSK error rates).
"""
