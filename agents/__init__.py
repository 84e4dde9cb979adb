"""What a robot runs: the neural implicit map, the consensus methods, neighbour copies
and the SimPy processes of one agent. Installed as ``ramensim.agents``; imports only
``ramensim.core`` besides itself."""
