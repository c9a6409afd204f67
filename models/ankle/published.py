"""The paper's published numbers (*cyberlegs-maccepa-energetics*, ``docs/paper.md``): what the report and the
claims compare the simulation with. Nothing else in the models reads them."""

#: the paper's numbers (section 4, Table 1, Figs. 7-13, 15)
PAPER = {
    "table1_energy": {"source": 64.5, "driver": 42.0, "motor": 33.0, "link": 15.4, "output": 12.0},  # J, 8 mm, 2 s
    "table1_efficiency": {"source": 1.0, "driver": 0.651, "motor": 0.512, "link": 0.239, "output": 0.186},
    "table1_loss": {"source": 0.0, "driver": 0.349, "motor": 0.214, "link": 0.533, "output": 0.221},
    "fig7_energy_actuator": 122.0,  # J/stride, 8 mm, 3 s/stride, "one of the first experiments"
    "fig7_energy_direct": 126.0,
    "fig7_peak_ratio": 1.40,  # direct-drive (output motor) peak / actuator peak at the driver input
    "fig8_driver_min_power": -50.0,  # W, driver power's negative peak (source stays about 0 W)
    "fig9_driver_loss_range": (0.286, 0.493),
    "fig11_gearing_loss_min": 0.50,  # "never below 50 %", "over 65 %" at high P and short strides
    "fig11_gearing_loss_worst": 0.65,
    "fig12_output_loss_typical": 0.20,  # "around 20 %", "over 50 % in the worst case"
    "fig12_output_loss_worst": 0.50,
    "fig15_efficiency_8mm_2s": 0.186,  # Table 1's overall efficiency
    "table2_R": (0.7, 2.0),  # ohm: Table 2 estimated total -> optimized total (Eq. 4 calibration)
}
