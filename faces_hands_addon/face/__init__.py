# SPDX-License-Identifier: GPL-3.0-or-later
"""The MEDUSA head (thesis 3.1.2): template skin, skull fit, muscles, direct parameters, the face rig."""
