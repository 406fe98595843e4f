"""ground_station: watches the fleet over Zenoh and logs it to Rerun."""
