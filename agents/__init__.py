"""What a robot runs: the neural implicit map, the consensus methods, neighbour copies
and the SimPy processes of one agent. Imports ``channels`` at most."""
