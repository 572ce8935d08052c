"""The interfaces: PettingZoo parallel (the step loop), AEC, and Gymnasium."""
