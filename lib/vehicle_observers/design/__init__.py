"""LMI synthesis of observers with certificates independent of the solver.

Modules, one concept each: :mod:`.lmi` (LMIs posed from builders, eigenvalue certificates,
Chilali-Gahinet regions), :mod:`.system` (a polytopic / TS system as vertex data),
:mod:`.constraints` (decay rate, regions, bounded-real lemma, input-to-state gain, Metzler
structure), :mod:`.synthesis` (gain structures, relaxations, optimise -> back off -> certify),
:mod:`.certify` (the certificate rebuilt from the data, H-infinity norms by Hamiltonian
bisection), :mod:`.uio` (unknown-input decoupling and the slack-variable LMI).
"""
