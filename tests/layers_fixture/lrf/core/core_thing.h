#pragma once
// A header on the lowest floor.
