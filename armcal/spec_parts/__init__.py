"""The parts of the spec language below the instruments: the strict base model, quantities and parameters (base.py),
the robot section (robot.py), what every device section shares (instrument.py) and the text of starting specs
(starter.py). armcal/spec/ assembles the whole document from them and the instruments' own sections (armcal/devices/)."""
